"""`hadim report`: the tables and figures of docs/results.md, made from a store and a sweep.

`summary` reads the sweep's runs into plain numbers (summary.json); `tables` writes the
markdown tables; `write_report` puts both and the figures into a folder.
"""
