"""The graph sampler's options: its `--option key=value` settings, as a pydantic model.

Kept apart from sampler.py so that listing plugins (`grammarkit plugins`) does not import
numpy, trimesh and manifold3d.
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field


class SamplerOptions(BaseModel):
    """Parameters of the method (defaults follow the paper and the authors' code); these are
    the graph sampler's `--option key=value` settings."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    tolerance: float = Field(0.1, gt=0, description="pairwise centroid distances: |d1 - d2| <= "
                             "tolerance x part size")
    dock_tolerance: float = Field(0.01, gt=0, description="boundary misalignment after Kabsch, "
                                  "relative to the boundary's bounding-box diagonal")
    min_subgraph: int = Field(4, ge=3, description="smallest sampled subgraph")
    max_subgraph_fraction: float = Field(0.75, gt=0, le=1, description="largest sampled subgraph, "
                                         "as a fraction of the donor's parts")
    keep_prob: float = Field(0.5, gt=0, le=1, description="randomised BFS: chance a seen "
                             "neighbour joins in a round")
    attempts_per_shape: int = Field(256, ge=1, description="attempts per iteration per new shape "
                                    "of the last iteration")
    min_attempts: int = Field(512, ge=1, description="attempts per iteration, at least")
    max_attempts: int = Field(100000, ge=1, description="attempts per iteration, at most")
    batch_size: int = Field(128, ge=1, description="attempts evaluated against the same state "
                            "(fixed: determinism)")
    dedupe: Literal["histogram", "isomorphism"] = Field("isomorphism", description="what counts "
                                                        "as new: typed graph (up to isomorphism) or type "
                                                        "histogram (fewer: the castle runs dry at 32)")
    counts: Literal["examples", "grammar"] = Field("examples", description="part counts a variant "
                                                  "may have: each type's fewest..most over the examples "
                                                  "(two or more examples; issue 28) or whatever the "
                                                  "grammar's own count constraints allow")
    max_parts: Optional[int] = Field(None, ge=1, description="largest variant (default: 4 x the "
                                     "largest example)")
    max_match_steps: int = Field(2000, ge=1, description="assignments tried per boundary search")
    contact_tolerance: Optional[float] = Field(None, gt=0, description="absolute contact distance "
                                               "(default: from the examples' scale)")
    max_iterations: int = Field(64, ge=1, description="iteration cap: a run goes on until -n new "
                                "variants, this many iterations (or --iterations, if larger), an "
                                "iteration that finds nothing new, or --time-limit")
    final_check: bool = Field(True, description="validate every variant with `grammarkit validate`'s "
                              "rules and defaults before it is kept (a variant it rejects is dropped "
                              "and counted as `final-check`)")
    geometric_keys: bool = Field(True, description="isomorphism dedupe: drop an attempt whose "
                                 "parts sit where a known shape's do before any contact is measured "
                                 "(False: the graph test after validation only; a benchmark baseline)")
    incremental: bool = Field(True, description="recompute only contacts involving inserted parts "
                              "(False: the whole graph; a benchmark baseline)")
