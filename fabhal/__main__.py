from fabhal.cli import main

raise SystemExit(main())
