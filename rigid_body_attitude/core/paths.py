"""Where the package's shipped files (``config/``) are found, installed or in a source tree."""

from __future__ import annotations

import os
from pathlib import Path
import sys

__all__ = ['config_folders']

PACKAGE_NAME = 'rigid_body_attitude'


def config_folders(subfolder: str = '') -> list[Path]:
    """Existing ``share/rigid_body_attitude/config/<subfolder>`` folders, first match wins.

    Looked for under this interpreter's prefix, then every ``AMENT_PREFIX_PATH`` entry, then
    the source tree this module sits in.
    """
    prefixes = [Path(sys.prefix)] + [
        Path(prefix) for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
        if prefix]
    folders = [prefix / 'share' / PACKAGE_NAME / 'config' / subfolder for prefix in prefixes]
    folders.append(Path(__file__).resolve().parents[2] / 'config' / subfolder)
    return [folder for folder in folders if folder.is_dir()]
