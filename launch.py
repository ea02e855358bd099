#!/usr/bin/env python3
"""Entry point: ``python launch.py [COMMAND ...]`` (same as the ``grasp-ctrl`` script)."""

import sys

from grasp_ctrl.cli import main

if __name__ == "__main__":
    sys.exit(main())
