"""Record the shipped model's estimates on the two fixed test images (``tests/net/golden_image.py``)
into ``tests/net/data/golden_estimate.npz``, with the model files' sha256.

``tests/net/test_fast_paths.py`` checks every later inference change against this record, so
run it once when a new model is shipped (``tools/train_shipped_model.py --install``), on the
commit that ships it, before changing inference code::

    .venv/bin/python tools/record_golden_estimate.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pressurepose.files import save_npz_atomic  # noqa: E402
from pressurepose.net.infer import estimate  # noqa: E402
from tests.net.golden_image import fixed_images  # noqa: E402
from tests.net.test_fast_paths import GOLDEN, _shipped_model_sha256  # noqa: E402


def main() -> int:
    torch.set_num_threads(1)
    sha = _shipped_model_sha256()
    if sha is None:
        print("no shipped model in pressurepose/net/assets/", file=sys.stderr)
        return 2
    est = estimate(fixed_images(), ["f", "m"])
    save_npz_atomic(GOLDEN, model_sha256=np.array(sha), betas=est.betas, pose=est.pose, transl=est.transl,
                    joints=est.joints, mod1_joints=est.mod1_joints, vertices=est.vertices[:, ::50], q=est.q,
                    contact=est.contact)
    print(f"wrote {GOLDEN} for model {sha[:12]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
