"""The FIFO tabu list of section 5.3."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable


class TabuList:
    """Tasks removed by accepted moves; tabu tasks may not be inserted (section 5.3).

    A FIFO of length ``L``: when full, the task added earliest is freed first. A task added
    twice stays tabu until both entries have left (membership counted per entry).

    Parameters
    ----------
    length
        L (the paper: N/50); 0 disables the list.
    """

    def __init__(self, length: int) -> None:
        self.length = length
        self._queue: deque[int] = deque()
        self._count: dict[int, int] = {}

    def __contains__(self, task: int) -> bool:
        return task in self._count

    def __len__(self) -> int:
        return len(self._queue)

    def add(self, tasks: Iterable[int]) -> None:
        """Append tasks in order, freeing the oldest while the list is over length."""
        if self.length <= 0:
            return
        q, cnt = self._queue, self._count
        for t in tasks:
            q.append(t)
            cnt[t] = cnt.get(t, 0) + 1
            if len(q) > self.length:
                old = q.popleft()
                cnt[old] -= 1
                if not cnt[old]:
                    del cnt[old]

    def items(self) -> list[int]:
        """Entries, oldest first."""
        return list(self._queue)
