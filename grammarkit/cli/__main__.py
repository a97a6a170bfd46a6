"""`python -m grammarkit.cli` runs the `grammarkit` command."""
from . import main

main()
