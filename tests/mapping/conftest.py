"""Make the synthetic-frame helpers (``mapping_synth``) importable by the mapping tests."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
