from contactnet.cli import main

raise SystemExit(main())
