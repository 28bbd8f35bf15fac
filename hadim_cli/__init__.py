"""hadim: hierarchical affordance discovery using intrinsic motivation (Manoury et al., 2019)."""

__version__ = "0.1.0"
