from pedvr.cli import main

raise SystemExit(main())
