"""``python -m pressurepose VERB ...``: the same as the ``pressurepose`` command."""

from pressurepose.cli import main

raise SystemExit(main())
