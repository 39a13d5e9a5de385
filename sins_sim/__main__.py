"""``python -m sins_sim``: the same command line as ``sins-sim`` (:func:`sins_sim.cli.main`).

Useful where the console script is not on ``PATH`` (a virtual environment that is not activated,
``python -m pip install --user``), and to be sure which interpreter runs it.
"""

import sys

from sins_sim.cli import main

if __name__ == "__main__":
    sys.exit(main())
