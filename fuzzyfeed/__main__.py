import sys

from fuzzyfeed.cli import main

sys.exit(main())
