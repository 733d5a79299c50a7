"""pressurepose: 3D body pose and shape from bed pressure images (Bodies at Rest, open).

Subpackages: ``body`` (body model, body sites), ``pose`` (sampler), ``sim`` (physics), ``data``
(datasets, real-mat readers), ``net`` (PressureNet: training, ``estimate``), ``eval`` (metrics,
real-image scoring, monitoring a night), ``calibrate`` (fitting the bed and sensor), ``viz``
(pictures), ``cli`` (the ``pressurepose`` command); below them ``mat`` (the mat's geometry),
``files`` (atomic files) and ``errors`` (:class:`BadInput`, raised for bad input). Import what you
need from them; this top level stays light so ``import pressurepose`` is fast.
"""

__version__ = "0.1.0"

from pressurepose.errors import BadInput

__all__ = ["BadInput", "__version__"]
