"""``python -m rigid_body_attitude.tools.study``: the ``accuracy_study`` console script."""

import sys

from rigid_body_attitude.tools.study.cli import main

sys.exit(main())
