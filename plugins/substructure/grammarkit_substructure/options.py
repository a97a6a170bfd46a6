"""The substructure back end's options (`--option key=value`), as a pydantic model.

Kept apart from the algorithm so that `grammarkit plugins` does not import numpy or trimesh.
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field


class SubstructureOptions(BaseModel):
    """Parameters of Liu et al. 2015 (defaults follow the paper where it gives one)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    q: int = Field(0, ge=0, le=4, description="ordering violations tolerated per match (dummy "
                   "edges; searched exhaustively, exponential in q; the paper uses q <= 2)")
    embedding: Literal["rigid", "non-rigid"] = Field("rigid", description="interpolate the "
                                                     "boundary transforms per part (rigid) or per "
                                                     "vertex (non-rigid, blend skinning)")
    frame_origin: Literal["foot", "centre"] = Field("foot", description="where a boundary frame "
                                                     "sits: the centre of the two parts' bounding-box "
                                                     "intersection seen from above, at its foot along "
                                                     "the up axis (so rigid copies keep their floor), "
                                                     "or at its centre (`centre`, the paper's)")
    repair: bool = Field(False, description="greedy part rescaling (along z) when the embedded "
                         "shape breaks a constraint, as the paper suggests: it deforms parts (no "
                         "longer rigid copies of their prototypes), so it is off by default and every "
                         "result it touched says `repaired` (rescaled parts) in its manifest record")
    orientation_degrees: float = Field(20.0, gt=0, lt=45, description="orientation check: "
                                       "consecutive cut edges within this angle of parallel "
                                       "may not become perpendicular, and vice versa")
    operations: int = Field(4, ge=1, le=100, description="operations chained per candidate "
                            "(at least --iterations); every shape along the chain is a result")
    tries: int = Field(64, ge=1, description="operations tried per step before a candidate "
                       "gives up (each one embedded and validated)")
    max_candidates: int = Field(20000, ge=1, description="candidates tried in all before the "
                                "run stops short")
    patience: int = Field(400, ge=1, description="stop after this many candidates in a row "
                          "gave nothing new")
    max_parts: Optional[int] = Field(None, ge=1, description="largest variant (default: 4 x "
                                     "the largest example)")
    dedupe: Literal["isomorphism", "none"] = Field("isomorphism", description="skip variants "
                                                   "whose typed graph equals an earlier one's "
                                                   "or an example's")
    counts: Literal["examples", "grammar"] = Field("examples", description="keep every variant's "
                                                   "number of parts of each type within the examples' "
                                                   "range (fewest..most; with two or more examples), "
                                                   "or only within what the grammar's count "
                                                   "constraints allow (`grammar`)")
    reuse_geometry: bool = Field(True, description="keep each placed example part's contact data, "
                                 "frame and support verdicts across embeddings (rigid embedding; "
                                 "`false`: recompute them every time, the former behaviour, same results)")
    memo: bool = Field(True, description="keep every evaluation on a shape reached by a chain of "
                       "operations (its operations, trivial verdicts and embeddings), named by the "
                       "chain, for the whole run: candidates that start alike reuse them (`false`: "
                       "evaluate each candidate afresh, the former behaviour, same results)")
    final_check: bool = Field(True, description="validate every variant with `grammarkit validate`'s "
                              "rules and defaults before it is written (one it rejects is dropped and "
                              "counted)")
    contact_tolerance: Optional[float] = Field(None, gt=0, description="absolute contact "
                                               "distance (default: from the examples' scale)")
