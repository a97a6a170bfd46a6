"""Shared test data of the QA tests."""
from __future__ import annotations

SMALL = """grammar small
attr h = 9 @range(6, 15)
attr style = "flat" @enum("flat", "hip")
attr win = true
Lot --> footprint(rect(8, 6)) extrude(h) Mass
Mass --> comp(f) { top: Top | side: Facade | bottom: NIL | volume: Mass. }
Top --> case style == "hip": roofHip(30) Roof. else: Roof.
Facade --> split(y) { { ~3: Floor }* }
Floor --> split(x) { ~1: Wall. | { 1.2: Window | ~1: Wall. }* }
Window --> case win: offset(-0.1) { inside: Glass. | border: Frame. } else: Wall.
"""
