"""`python -m contactnet.cli` runs the command line, as `python -m contactnet` and `contactnet` do."""
from contactnet.cli import main

raise SystemExit(main())
