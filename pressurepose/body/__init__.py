"""Body model: SMPL-format loading, numpy and torch skinning, capsules, masses.

>>> from pressurepose.body import BodyModel
>>> body = BodyModel("female")
"""

from pressurepose.body.joints import JOINT_NAMES, NUM_BETAS, NUM_JOINTS, PARENTS
from pressurepose.body.mesh import mesh_volume, points_inside
from pressurepose.body.model import GENDERS, BodyModel, canonical_gender
from pressurepose.body.smpl_io import SmplArrays, load_body_arrays, save_body_arrays

__all__ = ["BodyModel", "SmplArrays", "load_body_arrays", "save_body_arrays", "JOINT_NAMES", "PARENTS",
           "NUM_JOINTS", "NUM_BETAS", "GENDERS", "canonical_gender", "mesh_volume", "points_inside"]
