"""`python -m skin.sim CONFIG RECORDING LOAD`: the force calibration rig's two files (see
`skin.sim.rig`)."""

import sys

from .rig import main

sys.exit(main())
