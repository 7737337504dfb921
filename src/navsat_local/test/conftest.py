import os
import sys

# The package's modules without a built workspace (tests/run_all.sh runs every package's test/ from the root).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
