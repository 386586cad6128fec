"""``python -m robodcn``: the robodcn command line (:mod:`robodcn.cli`)."""

import sys

from robodcn.cli import main

sys.exit(main())
