"""Names of the settles a dataset can be made with (``GenerationConfig.settle``, ``--settle``), in a
module of their own so that datasets and commands can check a name without loading MuJoCo.

:func:`pressurepose.sim.settle_config.settle_preset` turns a name into its settle config.
"""

SETTLES: tuple[str, ...] = ("relaxed", "paper")
