"""`python -m trajdb [OUT]`: the demo in stock DuckDB (simulate, pipeline, score)."""
import sys

from . import demo

demo(*sys.argv[1:2])
