"""The generation progress bar: samples done, samples/s, ETA and the running rejection rate (tqdm)."""

from __future__ import annotations

import sys

from tqdm import tqdm


class ProgressBar:
    """Counts accepted samples live (per attempt, where the executor reports them) and settles each
    shard's exact counts when its result arrives; a failed shard's live counts are taken back."""

    def __init__(self, total: int, initial: int = 0, enabled: bool = True, desc: str = ""):
        self.bar = tqdm(total=total, initial=initial, unit="sample", desc=desc, disable=not enabled,
                        dynamic_ncols=True, smoothing=0.05, file=sys.stderr)
        self.live: dict[int, list[int]] = {}  # shard -> [accepted, rejected] not yet settled
        self.done: set[int] = set()
        self.accepted = 0  # this run's attempts, for the rejection rate
        self.rejected = 0

    def _postfix(self) -> None:
        tries = self.accepted + self.rejected
        if tries:
            self.bar.set_postfix_str(f"rejected {100.0 * self.rejected / tries:.1f}%", refresh=False)

    def attempt(self, shard: int, accepted: int, rejected: int) -> None:
        if shard in self.done:
            return
        live = self.live.setdefault(shard, [0, 0])
        live[0] += accepted
        live[1] += rejected
        self.accepted += accepted
        self.rejected += rejected
        self._postfix()
        if accepted:
            self.bar.update(accepted)

    def unit_done(self, result) -> None:
        live = self.live.pop(result.shard, [0, 0])
        self.done.add(result.shard)
        rejected = result.attempts - result.count
        self.accepted += result.count - live[0]
        self.rejected += rejected - live[1]
        self._postfix()
        self.bar.update(result.count - live[0])

    def unit_failed(self, unit, message: str) -> None:
        live = self.live.pop(unit.shard, [0, 0])
        self.accepted -= live[0]
        self.rejected -= live[1]
        if live[0]:
            self.bar.update(-live[0])
        self.bar.write(f"retrying {unit} after an error: {message.splitlines()[0]}", file=sys.stderr)

    def close(self) -> None:
        self.bar.close()
