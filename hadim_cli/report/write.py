"""Everything `hadim report` writes into its folder."""

from __future__ import annotations

import json
from pathlib import Path

from hadim_cli.errors import HadimError
from hadim_cli.report import summary as summaries
from hadim_cli.report import tables

REFERENCE = "default"


def report_iterations(summary: dict, wanted: list[int] | None) -> list[int]:
    """The iterations of the score table: the wanted ones, else up to 5 spread over the
    evaluated iterations (always the first and the last)."""
    if wanted:
        return wanted
    evaluated = sorted({int(it) for cfg in summary["configs"].values()
                        for by_it in cfg.values() for it in by_it})
    if len(evaluated) <= 5:
        return evaluated
    picks = {evaluated[round(i * (len(evaluated) - 1) / 4)] for i in range(5)}
    return sorted(picks)


def write_report(store, sweep: str, out: Path, at: list[int] | None = None) -> list[Path]:
    """summary.json, tables.md, competence.png (if the runs were evaluated) and
    timelines/RUN.png into `out`; returns the files written."""
    from hadim_cli.plots import comparison_figure, timeline_figure

    groups = summaries.sweep_groups(store, sweep)
    try:
        (out / "timelines").mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise HadimError(f"cannot write the report to {out}: {exc.strerror or exc}") from None
    summary = summaries.build_summary(store, groups)
    written = [out / "summary.json", out / "tables.md"]
    evaluations = {label: [store.evaluations(n) for n in names] for label, names in groups.items()}
    if any(evs for runs in evaluations.values() for evs in runs):  # else: trained with no eval
        written.append(out / "competence.png")
        comparison_figure(evaluations, written[-1], tables.TASKS)
    for names in groups.values():
        for name in names:
            path = out / "timelines" / f"{name}.png"
            timeline_figure(store.events(name), store.get_run(name).iterations, path)
            written.append(path)
    written[0].write_text(json.dumps(summary, indent=1, sort_keys=True))
    reference = REFERENCE if REFERENCE in groups else next(iter(groups))
    run_md, counts = tables.run_table(store, groups[reference])
    parts = [f"# Sweep {sweep}", "## Scores (mean ± std over seeds)",
             tables.score_table(summary, report_iterations(summary, at)),
             "## The paper's targets", tables.target_table(summary, reference),
             f"## H at the end, per seed ({reference})", run_md, tables.counts_line(counts)]
    written[1].write_text("\n\n".join(parts) + "\n")
    return written
