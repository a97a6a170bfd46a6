"""CGA parse tree -> grammarkit IR (see translator.py)."""
from .translator import Translator

__all__ = ["Translator"]
