"""`python -m grammarkit` runs the `grammarkit` command."""
from .cli import main

main()
