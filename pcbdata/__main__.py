import sys

from pcbdata.cli import main

sys.exit(main())
