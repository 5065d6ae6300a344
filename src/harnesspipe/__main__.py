from harnesspipe.cli import main

raise SystemExit(main())
