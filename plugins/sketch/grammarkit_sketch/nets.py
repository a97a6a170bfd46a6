"""The networks (torch; imported only when recognising or training).

Nishida et al. 2016 fine-tune an ImageNet AlexNet (61M parameters, 256x256 input) as the
snippet classifier of each object type and train a small regression CNN per snippet (3 conv +
2 fully connected layers, 128x128) from scratch. No pretrained weights can be downloaded here,
and the paper's own Table 1 shows AlexNet from scratch doing worse than fine-tuned (0.86-0.92).
Our drawings are clean synthetic line drawings of a handful of classes, so a small CNN
trained from scratch is enough (see docs/sketch.md for the accuracy it reaches):

- `build_classifier`: 4 conv layers (16-32-32-32 channels, batch norm) and 2 fully
  connected layers on the 128x128 input, ~57k parameters.
- `build_regressor`: the paper's 3 conv + 2 FC layout at 128x128, with two extra input
  channels holding the pixel coordinates (CoordConv, Liu et al. 2018): parameters are mostly
  positions and lengths, which plain convolutions (translation-invariant) estimate poorly.
  The last conv map is kept at 8x8 (averaging it down to 4x4 cost 40% more RMSE in a test on
  the roofs). A sigmoid keeps the outputs in the normalised range [0, 1]. ~76k parameters.
"""
from __future__ import annotations

from typing import Any

from grammarkit.errors import GrammarkitError

INSTALL_HINT = ('install the learning extra: python -m pip install "grammarkit[learning]" '
                "-c constraints.txt (from a source tree: pip install -e \".[learning]\" -c constraints.txt)")


class MissingTorchError(GrammarkitError):
    """torch (the `learning` extra) is not installed."""


def require_torch() -> Any:
    try:
        import torch
    except ImportError:
        raise MissingTorchError("the sketch recognizer needs torch, which is not installed", None,
                                hint=INSTALL_HINT, code="sketch-no-torch") from None
    return torch


def build_classifier(n_classes: int, width: int = 16) -> Any:
    torch = require_torch()
    nn = torch.nn
    c1, c2 = width, 2 * width

    def block(i: int, o: int, k: int = 3, stride: int = 1) -> list:
        return [nn.Conv2d(i, o, k, stride=stride, padding=k // 2, bias=False), nn.BatchNorm2d(o),
                nn.ReLU(inplace=True)]

    return nn.Sequential(
        *block(1, c1, 5, 2), nn.MaxPool2d(2),          # 128 -> 32
        *block(c1, c2), nn.MaxPool2d(2),              # -> 16
        *block(c2, c2), nn.MaxPool2d(2),              # -> 8
        *block(c2, c2), nn.AdaptiveAvgPool2d(4),      # -> 4
        nn.Flatten(), nn.Linear(c2 * 16, 64), nn.ReLU(inplace=True), nn.Dropout(0.2),
        nn.Linear(64, n_classes))


class _CoordInput:
    """Factory of the CoordConv module (defined lazily: torch is optional)."""

    cls = None

    @classmethod
    def get(cls) -> Any:
        if cls.cls is None:
            torch = require_torch()

            class AddCoords(torch.nn.Module):
                def forward(self, x):  # noqa: ANN001, ANN201
                    n, _, h, w = x.shape
                    ys = torch.linspace(-1.0, 1.0, h, device=x.device, dtype=x.dtype)
                    xs = torch.linspace(-1.0, 1.0, w, device=x.device, dtype=x.dtype)
                    gy = ys.view(1, 1, h, 1).expand(n, 1, h, w)
                    gx = xs.view(1, 1, 1, w).expand(n, 1, h, w)
                    return torch.cat([x, gx, gy], dim=1)

            cls.cls = AddCoords
        return cls.cls()


def build_regressor(n_params: int, width: int = 16) -> Any:
    torch = require_torch()
    nn = torch.nn
    c1, c2 = width, 2 * width
    return nn.Sequential(
        _CoordInput.get(),
        nn.Conv2d(3, c1, 5, stride=2, padding=2), nn.ReLU(inplace=True), nn.MaxPool2d(2),   # -> 32
        nn.Conv2d(c1, c2, 3, padding=1), nn.ReLU(inplace=True), nn.MaxPool2d(2),            # -> 16
        nn.Conv2d(c2, c1, 3, padding=1), nn.ReLU(inplace=True), nn.MaxPool2d(2),            # -> 8
        nn.Flatten(), nn.Linear(c1 * 64, 64), nn.ReLU(inplace=True),
        nn.Linear(64, n_params), nn.Sigmoid())


def count_parameters(net: Any) -> int:
    return sum(int(p.numel()) for p in net.parameters())
