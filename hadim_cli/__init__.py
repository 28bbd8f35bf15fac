"""hadim: hierarchical affordance discovery using intrinsic motivation (Manoury et al., 2019)."""

from hadim_cli.numerics import pin_kernels

pin_kernels()  # before numpy loads: the same kernels, so the same runs, on every machine

__version__ = "0.3.0"
