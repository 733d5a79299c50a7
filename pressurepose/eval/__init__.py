"""Evaluation (no MuJoCo needed):

* ``metrics``: MPJPE, v2v, 3DVPE and the mean-pose baseline;
* ``report``: the accuracy table of a trained PressureNet on a simulated dataset (``evaluate``);
* ``posture``: posture class, stature and mass of an estimated body;
* ``real``: scoring a PressureNet on labelled real images (``evaluate_real``);
* ``realism`` / ``realism_report``: how simulated pressure images differ from real ones;
* ``monitor``: a recording over time (a night): posture, turns, pressure per body site, alerts.
"""
