"""The string-VAE back end's options: its `--option key=value` settings, as a pydantic model.

Kept apart from the sampler so that listing plugins does not import torch.
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field


class StringVAEOptions(BaseModel):
    """`grammarkit derive GRAMMAR --backend string-vae --option model=castle.vae ...`"""

    model_config = ConfigDict(extra="forbid", frozen=True, protected_namespaces=())

    model: Optional[str] = Field(None, description="the trained model file (.vae, from `grammarkit train "
                                 "string-vae`), or builtin:castle for the shipped one; default: the grammar's "
                                 "shipped model, with its shipped categories and placed decoding")
    mode: Literal["perturb", "interpolate", "path", "prior"] = Field(
        "perturb", description="latent sampling: around training points, between two, along a latent "
        "path, or from the prior N(0, I)")
    decoding: Optional[Literal["masked", "free", "placed"]] = Field(
        None, description="default: placed when the shipped models are used (no model option), else masked. "
        "masked: grammar-constrained, valid by construction; free: the paper's "
        "decoding, invalid strings dropped; placed: string and edge categories decoded together, every "
        "step masked by what can still be placed in 3D (needs categories; see docs/string-vae.md)")
    width: int = Field(16, ge=1, description="placed decoding: placements kept per written prefix")
    placed_steps: int = Field(150, ge=1, description="placed decoding: search steps per latent point")
    max_tokens: Optional[int] = Field(None, ge=2, description="size control: perturb, interpolate and path "
                                      "start only from training points whose string has at most this many tokens")
    max_length: Optional[int] = Field(None, ge=2, description="placed decoding's length prior: every sample's "
                                      "budget is the length of a random training string of at most this many "
                                      "tokens (start points stay the whole pool)")
    reach: bool = Field(True, description="placed decoding: mask placements by the chain reach table (the fewest "
                        "parts that can still dock to each open ring's owner; false: the straight-line bound only, "
                        "the earlier decoder) and rank the beam by it")
    max_open_rings: Optional[int] = Field(None, ge=1, description="placed decoding: no new ring label while this many "
                                          "are open (default: none; 2 with the shipped models)")
    min_length: Optional[int] = Field(None, ge=2, description="placed decoding's length prior: the bucket's "
                                      "lower end (budgets from training strings of min_length..max_length tokens)")
    slack: float = Field(0.15, ge=0, description="placed decoding: the length prior's slack (budget = the "
                         "start string's length x (1 + slack))")
    temperature: float = Field(0.0, ge=0, description="0: most likely token; > 0: sample tokens")
    magnitude: float = Field(0.25, gt=0, description="perturb: largest latent offset per dimension "
                             "(paper: 0.25)")
    steps: int = Field(8, ge=1, description="perturb: offset magnitudes tried per training point")
    local_magnitude: float = Field(0.1, gt=0, description="interpolate/path: offsets around each point")
    points: int = Field(8, ge=1, description="interpolate: points per segment")
    path_length: int = Field(32, ge=2, description="path: latent points per path (paper: 32)")
    batch: int = Field(128, ge=1, description="latent points decoded together")
    max_decodes: Optional[int] = Field(None, ge=1, description="stop after decoding this many latent "
                                       "points (default: 200 x n)")
    patience: int = Field(60, ge=1, description="stop after this many decoded latent points without a new "
                          "shape (and say why)")
    search_past_known: bool = Field(True, description="perturb/interpolate/path: grow the offset past decoded "
                                    "graphs that are training graphs or made already (the paper's \"until a new "
                                    "valid string\"); false: stop at any graph other than the start point's")
    novel_search: bool = Field(True, description="placed decoding: a finished string whose graph is a training "
                               "graph or made already is a dead end of the search, which goes on to the next "
                               "alternative (needs search_past_known); false: such points are lost to novelty")
    finish_check: bool = Field(True, description="placed decoding: build and check every finished string at once "
                               "(the global constraints: filled, grounded, path); one that fails is a dead end of "
                               "the search, which goes on to a string that builds")
    per_point: int = Field(1, ge=1, description="placed decoding: new graphs searched per latent point (the search "
                           "goes on after a finished string; the further ones share the point's prefix)")
    include_training: bool = Field(False, description="also yield graphs of the training set")
    categories: Optional[str] = Field(None, description="edge-category model (.edges, from `grammarkit train "
                                      "edge-categories`, or builtin:castle for the shipped one): instantiate every "
                                      "graph in 3D and write it as a shape")
    tries: int = Field(8, ge=1, description="instantiation: start edges tried per graph")
    votes: int = Field(8, ge=1, description="instantiation: strings per graph that vote on each edge's category")
    voting: Optional[Literal["majority", "logprob", "joint"]] = Field(
        None, description="instantiation: how the strings' predictions are combined: majority (the paper's), "
        "logprob (summed log-probabilities) or joint (per part, configurations seen in training); default: "
        "the category model's own")
    budget: int = Field(400, ge=1, description="instantiation: part insertions per try (backtracking included); "
                        "smaller fails faster on graphs that cannot be built")
    search: Literal["consistent", "backtracking", "consistent+backtracking"] = Field(
        "consistent", description="instantiation: consistent (a beam search over the summed log-probability "
        "votes for categories that close every cycle without collisions; a graph it finds none for is "
        "skipped at once), backtracking (the paper's insertion with Monte-Carlo fallback, `tries` start "
        "edges of `budget` insertions), or the consistent search first and backtracking when it fails")
    beam: int = Field(16, ge=1, description="consistent search: placements kept per part (8 times as many "
                      "once more when the beam empties)")
    max_parts: Optional[int] = Field(None, ge=1, description="skip sampled graphs with more parts than this "
                                     "before instantiating them (default: no limit)")
