#!/usr/bin/env python3
"""Entry point: ``python launch.py [COMMAND ...]`` (same as the ``grasp-ctrl`` script)."""

import sys

if __name__ == "__main__":
    try:
        from grasp_ctrl.cli import main
    except KeyboardInterrupt:  # Ctrl-C while the interpreter loads the package: no traceback
        sys.exit(130)
    sys.exit(main())
