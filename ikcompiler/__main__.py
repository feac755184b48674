"""``python -m ikcompiler ...`` runs the ``ikc`` command line (the same as the console script)."""

import sys

from ikcompiler.cli import main

if __name__ == "__main__":  # tests/conftest.py imports every module: do not run the CLI then
    sys.exit(main())
