import sys

from robrst.cli import main

sys.exit(main())
