"""A progress reporter for tests: keeps the tasks it was asked to show and the steps counted."""

from __future__ import annotations


class Recorder:
    """Implements ``neckid.utils.progress.Reporter`` and its handle: ``started`` and ``steps``."""

    def __init__(self) -> None:
        self.started: list[tuple[str, float | None]] = []
        self.steps = 0.0

    def start(self, label: str, total: float | None) -> Recorder:
        self.started.append((label, total))
        return self

    def advance(self, steps: float = 1.0) -> None:
        self.steps += steps

    def stop(self) -> None:
        pass
