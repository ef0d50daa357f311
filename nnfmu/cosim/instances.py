"""FMU instances kept between co-simulations and reset instead of loaded anew.

Opening an FMU (extract, load its library, instantiate) costs ~10 ms, a quarter-car case on the compiled inner
loop ~20 ms: a campaign running many drives through the same FMUs spends half its time opening them. A pool hands a
run instances it kept from an earlier run (after fmi2Reset/fmi3Reset: back to the state right after instantiation,
every variable at its start value) and takes them back afterwards. Instances are known by the FMU file (path, size
and modification time, so a rebuilt FMU is opened afresh) and the instance name. An instance that took part in a
failed run is never kept, nor one whose terminate or reset fails; the pool keeps at most `capacity` idle instances,
closing the longest unused.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

from nnfmu.cosim.slave import FmuSlave

DEFAULT_CAPACITY = 64  # idle instances kept: 9 FMUs of a full vehicle x several variants
_Key = tuple[str, int, int, str]


def _key(path: Path, instance_name: str) -> _Key:
    stat = path.stat()
    return str(path.resolve()), stat.st_size, stat.st_mtime_ns, instance_name


class InstancePool:
    """Idle FMU instances by file and instance name, reset and ready for a new run."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 0:
            raise ValueError(f"an instance pool's capacity must be >= 0, not {capacity}")
        self.capacity = capacity
        self.opened = 0  # instances opened (loaded and instantiated) by this pool
        self.reused = 0  # runs served by a kept instance
        self._idle: OrderedDict[_Key, list[FmuSlave]] = OrderedDict()
        self._keys: dict[int, _Key] = {}  # id(slave) -> its key, for the instances handed out

    def __len__(self) -> int:
        return sum(len(slaves) for slaves in self._idle.values())

    def take(self, path: str | Path, instance_name: str, unpacked: bool = False) -> FmuSlave:
        """A reset instance of the FMU at `path` (with `unpacked`: a folder, `FmuSlave`), kept from an earlier run if
        there is one, else opened now."""
        key = _key(Path(path), instance_name)
        idle = self._idle.get(key)
        if idle:
            slave = idle.pop()
            if not idle:
                del self._idle[key]
            self.reused += 1
        else:
            slave = FmuSlave(path, instance_name=instance_name, unpacked=unpacked)
            self.opened += 1
        self._keys[id(slave)] = key
        return slave

    def give(self, slave: FmuSlave, healthy: bool) -> None:
        """Take back an instance handed out by `take`: reset and kept if its run went well, else closed."""
        from fmpy.fmi1 import FMICallException

        key = self._keys.pop(id(slave), None)
        if key is None or not healthy or self.capacity == 0:
            slave.close()
            return
        try:
            slave.reset()
        except FMICallException:
            slave.close()
            return
        self._idle.setdefault(key, []).append(slave)
        self._idle.move_to_end(key)
        while len(self) > self.capacity:
            oldest = next(iter(self._idle))
            slaves = self._idle[oldest]
            slaves.pop(0).close()
            if not slaves:
                del self._idle[oldest]

    def close(self) -> None:
        """Close every idle instance."""
        while self._idle:
            _, slaves = self._idle.popitem()
            for slave in slaves:
                slave.close()
