"""``python -m rigid_body_attitude.tools.campaign``: the ``campaign`` command."""

import sys

from rigid_body_attitude.tools.campaign.cli import main

sys.exit(main())
