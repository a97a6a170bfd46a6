"""The sequence VAE (torch): a convolutional encoder, a GRU decoder conditioned on z.

In the style of the chemical VAE (Gomez-Bombarelli et al. 2018) and Bowman et al.'s sentence
VAE (2016): strings are token sequences (one-hot through an embedding); a convolutional
encoder gives the mean and log-variance of q(z | x); the decoder is an autoregressive GRU
(teacher forcing in training) that sees z at every step and in its initial state. Against posterior
collapse: KL warm-up (the KL weight grows from 0) and word dropout (decoder inputs replaced
by UNK at random), both in train.py.

This module imports torch; grammarkit_string_vae imports it only when a model is used.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn

from .vocab import BOS, PAD

__all__ = ["ModelConfig", "StringVAE"]


@dataclass(frozen=True)
class ModelConfig:
    vocab_size: int
    max_len: int  # tokens per string, EOS included
    embed: int = 32
    conv: tuple[int, int, int] = (64, 64, 96)  # channels of the encoder's convolutions
    enc_hidden: int = 192  # the encoder's dense layer
    hidden: int = 192  # the decoder GRU
    latent: int = 56

    def to_json(self) -> dict:
        return asdict(self)


class StringVAE(nn.Module):
    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        c = config
        self.embed = nn.Embedding(c.vocab_size, c.embed, padding_idx=PAD)
        # chemical-VAE encoder: 1D convolutions (kernels 9, 9, 11) over the embedded string,
        # max-pooled over the positions that hold tokens, then a dense layer. Convolutions run
        # in parallel over the string: several times cheaper on a CPU than a recurrent encoder.
        k1, k2, k3 = c.conv
        self.conv = nn.ModuleList([nn.Conv1d(c.embed, k1, 9, padding=4), nn.Conv1d(k1, k2, 9, padding=4),
                                   nn.Conv1d(k2, k3, 11, padding=5)])
        self.dense = nn.Linear(k3, c.enc_hidden)
        self.to_mu = nn.Linear(c.enc_hidden, c.latent)
        self.to_logvar = nn.Linear(c.enc_hidden, c.latent)
        self.z_to_h = nn.Linear(c.latent, c.hidden)
        self.decoder = nn.GRU(c.embed + c.latent, c.hidden, batch_first=True)
        self.out = nn.Linear(c.hidden, c.vocab_size)

    # ---- encoder ---------------------------------------------------------------------------
    def encode(self, tokens: torch.Tensor, lengths: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """tokens (B, L) padded with PAD, lengths (B,) -> mu, logvar (B, latent)."""
        mask = (torch.arange(tokens.shape[1]).unsqueeze(0) < lengths.unsqueeze(1)).unsqueeze(1)  # (B, 1, L)
        x = self.embed(tokens).transpose(1, 2)  # (B, E, L)
        for conv in self.conv:
            x = torch.relu(conv(x * mask))
        x = x.masked_fill(~mask, float("-inf")).max(dim=2).values
        h = torch.relu(self.dense(x))
        return self.to_mu(h), self.to_logvar(h)

    # ---- decoder ---------------------------------------------------------------------------
    def initial_hidden(self, z: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.z_to_h(z)).unsqueeze(0)

    def decode_teacher(self, z: torch.Tensor, inputs: torch.Tensor) -> torch.Tensor:
        """Logits (B, L, V) for decoder inputs (B, L) (BOS then the string's tokens)."""
        emb = self.embed(inputs)
        zz = z.unsqueeze(1).expand(-1, inputs.shape[1], -1)
        out, _ = self.decoder(torch.cat([emb, zz], dim=2), self.initial_hidden(z))
        return self.out(out)

    def step(self, token: torch.Tensor, h: torch.Tensor, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """One decoder step: previous tokens (B,), hidden (1, B, H), z (B, latent) -> logits (B, V), hidden."""
        emb = self.embed(token).unsqueeze(1)
        out, h = self.decoder(torch.cat([emb, z.unsqueeze(1)], dim=2), h)
        return self.out(out[:, 0]), h

    def start(self, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Logits for the first token and the hidden state after BOS."""
        bos = torch.full((z.shape[0],), BOS, dtype=torch.long)
        return self.step(bos, self.initial_hidden(z), z)
