"""The token vocabulary of the sequence models: specials, one letter per type, brackets, ring labels.

Token ids: 0 PAD, 1 BOS (decoder start), 2 EOS (end of string), 3 UNK (word dropout: an
input the decoder cannot read), then the alphabet's letters, `(`, `)` and ring labels `1` ..
`R` (R: the largest label the training strings use; `%10` and above are one token each).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from grammarkit.errors import GrammarkitError

from .strings import Alphabet, ring_token, tokenize

__all__ = ["Vocab", "PAD", "BOS", "EOS", "UNK"]

PAD, BOS, EOS, UNK = 0, 1, 2, 3
SPECIALS = ("<pad>", "<bos>", "<eos>", "<unk>")


@dataclass(frozen=True)
class Vocab:
    alphabet: Alphabet
    rings: int  # ring labels 1..rings

    @property
    def tokens(self) -> tuple[str, ...]:
        return (*SPECIALS, *self.alphabet.letters, "(", ")",
                *(ring_token(r) for r in range(1, self.rings + 1)))

    def __len__(self) -> int:
        return len(SPECIALS) + len(self.alphabet.letters) + 2 + self.rings

    # ids of the structural tokens
    @property
    def first_letter(self) -> int:
        return len(SPECIALS)

    @property
    def open_id(self) -> int:
        return len(SPECIALS) + len(self.alphabet.letters)

    @property
    def close_id(self) -> int:
        return self.open_id + 1

    def ring_id(self, label: int) -> int:
        return self.close_id + label

    def letter_id(self, type_index: int) -> int:
        return self.first_letter + type_index

    def kind(self, token: int) -> tuple[str, int]:
        """("eos"|"node"|"open"|"close"|"ring"|"special", value)."""
        if token == EOS:
            return ("eos", 0)
        if token < len(SPECIALS):
            return ("special", token)
        if token < self.open_id:
            return ("node", token - self.first_letter)
        if token == self.open_id:
            return ("open", 0)
        if token == self.close_id:
            return ("close", 0)
        return ("ring", token - self.close_id)

    def encode(self, text: str) -> list[int]:
        """Token ids of a smiles-format string (without BOS/EOS)."""
        out = []
        letters = {c: k for k, c in enumerate(self.alphabet.letters)}
        for tok in tokenize(text, self.alphabet, "smiles"):
            if tok.kind == "node":
                out.append(self.letter_id(letters[tok.text]))
            elif tok.kind == "open":
                out.append(self.open_id)
            elif tok.kind == "close":
                out.append(self.close_id)
            else:
                if int(tok.value) > self.rings:
                    raise GrammarkitError(f"ring label {tok.text} is beyond the model's {self.rings} "
                                          "ring labels")
                out.append(self.ring_id(int(tok.value)))
        return out

    def decode(self, ids: Sequence[int]) -> str:
        """Text of token ids, stopping at EOS (PAD/BOS/UNK are skipped)."""
        toks = self.tokens
        out = []
        for t in ids:
            t = int(t)
            if t == EOS:
                break
            if t >= len(SPECIALS):
                out.append(toks[t])
        return "".join(out)

    def to_json(self) -> dict:
        return {"alphabet": self.alphabet.to_json(), "rings": self.rings, "tokens": list(self.tokens)}

    @classmethod
    def from_json(cls, data: dict) -> "Vocab":
        v = cls(Alphabet.from_json(data["alphabet"]), int(data["rings"]))
        if "tokens" in data and list(data["tokens"]) != list(v.tokens):
            raise GrammarkitError("the model's token list does not match its alphabet and ring count")
        return v
