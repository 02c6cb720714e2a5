from mjasc.cli import main

raise SystemExit(main())
