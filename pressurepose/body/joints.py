"""SMPL's 24-joint skeleton: names, parents and index helpers (pure data)."""

JOINT_NAMES: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2",
    "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot", "neck",
    "left_collar", "right_collar", "head", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hand", "right_hand",
)

# parent of each joint; -1 for the root. Same as SMPL's kintree_table[0].
PARENTS: tuple[int, ...] = (
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21,
)

NUM_JOINTS = 24
NUM_BETAS = 10

# left/right joint index pairs, for mirroring
MIRROR_PAIRS: tuple[tuple[int, int], ...] = tuple(
    (i, JOINT_NAMES.index("right_" + n[5:]))
    for i, n in enumerate(JOINT_NAMES) if n.startswith("left_")
)


def joint_index(name: str) -> int:
    """Index of an SMPL joint by name; raises BadInput naming the valid names."""
    from pressurepose.errors import BadInput

    try:
        return JOINT_NAMES.index(name)
    except ValueError:
        raise BadInput(f"unknown joint {name!r}; expected one of {', '.join(JOINT_NAMES)}") from None


def mirror_permutation() -> list[int]:
    """Permutation p with joints_mirrored = joints[p] (left <-> right)."""
    perm = list(range(NUM_JOINTS))
    for a, b in MIRROR_PAIRS:
        perm[a], perm[b] = b, a
    return perm
