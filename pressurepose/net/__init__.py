"""PressureNet (paper section 4, appendix B): pressure image + gender -> posed 3D body.

Modules (import from them; this package stays light):

* ``transforms``: blur, Sobel edges, contact map, x2 upsampling, per-image normalisation, input channels
* ``train_config``: the training options (``TrainConfig``, ``NoiseConfig``, the CNN's named widths,
  ``PAPER_TRAINING``: the paper's values where the defaults are not); no torch
* ``noise``: the training noise model
* ``cnn``: the paper's CNN (67,200 features -> 88 outputs for a 128 x 54 input)
* ``outputs`` / ``rotations``: soft-limited body parameters; root rotation from atan2 pairs (Euler)
* ``pmr``: differentiable sink-depth, pressure (Q) and contact maps from a mesh
* ``model``: ``PressureNet`` = Mod1 + Mod2 with the gendered body layer
* ``losses``: L1 and L2; ``train``: the training loop; ``checkpoint``: safe saving/loading; ``device``:
  the torch device a run or model uses, from its name
* ``infer``: ``estimate(pressure, gender, model) -> Estimate``; ``mirror``: averaging an image's reading
  with its mirror's; ``fit``: moving an estimated body onto its image's print; ``plausibility``: whether
  an image looks like a person lying on the mat; ``data``: generated datasets and training packs in
  memory (``load_dataset``)
* ``sitenet``: the site network, which reads the body site of each loaded taxel from the image and
  the estimated body's site map; ``sitenet_train``: its training
"""
