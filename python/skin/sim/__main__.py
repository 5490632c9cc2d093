"""`python -m skin.sim CONFIG RECORDING LOAD`: the force calibration rig's two files (see
`skin.sim.rig`)."""

from .rig import main

raise SystemExit(main())
