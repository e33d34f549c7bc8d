"""`python -m trajdb ...`: the `trajdb` command (python/trajdb/cli.py; `python -m trajdb help`)."""
import sys

from .cli import main

sys.exit(main())
