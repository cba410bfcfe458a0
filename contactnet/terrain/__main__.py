"""``python -m contactnet.terrain [--out DIR]``: regenerate the shipped terrain files."""

from contactnet.terrain.scenes import main

raise SystemExit(main())
