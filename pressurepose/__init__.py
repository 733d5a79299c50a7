"""pressurepose: 3D body pose and shape from bed pressure images (Bodies at Rest, open).

Subpackages: ``body`` (body model), ``pose`` (sampler), ``sim`` (physics), ``data`` (datasets),
``net`` (PressureNet), ``eval`` (metrics), ``viz`` (pictures). Import what you need from them;
this top level stays light so ``import pressurepose`` is fast.
"""

__version__ = "0.1.0"

from pressurepose.errors import BadInput

__all__ = ["BadInput", "__version__"]
