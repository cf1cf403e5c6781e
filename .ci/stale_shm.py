"""Remove Fast DDS shared-memory files that no running process holds.

A participant killed without its clean-up (a test run stopped with SIGKILL) leaves its
segments and port files in /dev/shm. A later participant that reuses such a port sees the
stale listener state: its own shared-memory listener then misses the wake-up period of the
packaged profile (test/ros/test_middleware.py). CI runs on a machine where earlier work may
have been killed, so it removes those files first; files that any live process has open or
mapped are kept.
"""

import os
from pathlib import Path

SHM = Path('/dev/shm')


def held_files() -> set[str]:
    """Every /dev/shm path a live process has open or mapped."""
    held: set[str] = set()
    for proc in Path('/proc').iterdir():
        if not proc.name.isdigit():
            continue
        try:
            for fd in (proc / 'fd').iterdir():
                target = os.readlink(fd)
                if target.startswith('/dev/shm/'):
                    held.add(target)
            for line in (proc / 'maps').read_text().splitlines():
                if '/dev/shm/' in line:
                    held.add(line[line.index('/dev/shm/'):].split(' (deleted)')[0])
        except OSError:  # the process ended meanwhile, or is not ours to read
            continue
    return held


def main() -> None:
    held = held_files()
    stale = [path for path in SHM.glob('*fastrtps*') if str(path) not in held]
    for path in stale:
        path.unlink(missing_ok=True)
    print(f'removed {len(stale)} stale Fast DDS shared-memory files from {SHM}')


if __name__ == '__main__':
    main()
