"""RandLA-Net (Hu et al., CVPR 2020: "RandLA-Net: Efficient Semantic Segmentation of Large-Scale
Point Clouds"), the first of the paper's three models, trained and run on the CPU with PyTorch
(``pip install 'genie-gl[neural]'``).

A sample is a crop: a centre point of a scan and its ``points`` nearest points (a scan with
fewer is padded with repeats of its own points, as the original does). Its input per point is
the offset from the centre in x and y and the height above the floor. The network is the
original's, narrower:

- a first fully connected layer to ``first`` channels (the original: 8);
- an encoder of ``len(widths)`` layers, each a *dilated residual block* (a shared MLP to d/2,
  two *local spatial encoding* + *attentive pooling* units, a shared MLP to 2d, plus a
  shortcut) on the points of its level, then *random sampling*: the level's points are in a
  random order, so the first 1/``ratio`` of them are a uniform random sample, and each sampled
  point max-pools the features of its ``k`` neighbours. Local spatial encoding: an MLP of
  (p_i, p_k, p_i - p_k, |p_i - p_k|) beside the neighbour's features; attentive pooling: a
  softmax over the ``k`` neighbours of a learnt score per channel, the weighted sum, an MLP;
- a decoder: each level up by nearest-neighbour interpolation, joined to the encoder's features
  of that level (skip), a shared MLP; then 64, 32, dropout 0.5, the classes.

Widths: the original's SemanticKITTI network has d = 16, 64, 128, 256 on 45 056-point samples;
the default here (8, 16, 32, 64 on 4 096 points, about 1/60th of the arithmetic per sample)
is what two shared CPU cores train in tens of minutes. Neighbours come from SciPy's
``cKDTree`` per crop and level. Training: Adam, cross-entropy weighted by ``(n_c) ** -balance``,
crops drawn at random (a scan in proportion to its points, a centre among its points), a fixed
number of steps; every ``validate_every`` steps the mIoU on fixed crops of held-out training
scenes, and the weights of the best one kept (the paper's "best checkpoint"). The learning
curve (step, epoch, seconds, validation mIoU, load) is kept in ``curve``.

Randomness: crops, sampling orders, initial weights and dropout all come from the run's
``rng`` (a ``torch.Generator`` and torch's CPU seed drawn from it): the same seed and thread
count give the same bytes. Prediction covers every point: crops are centred on the point
predicted the fewest times (the original's "possibility"), in a fixed order, and each point's
class is the argmax of its summed probabilities.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree
from tqdm import tqdm

from ..errors import ConfigError
from .classical import split_groups
from .features import PointTable
from .metrics import confusion, scores

log = logging.getLogger(__name__)


def _torch():
    try:
        import torch
    except ImportError:
        raise ConfigError(
            "RandLA-Net needs PyTorch: pip install 'genie-gl[neural]' "
            "(the CPU build, torch==2.13.0)"
        ) from None
    return torch


@dataclass(frozen=True)
class RandLAParams:
    """Settings of RandLA-Net (see the module's docstring)."""

    points: int = 4096
    k: int = 16
    widths: tuple[int, ...] = (8, 16, 32, 64)
    ratio: int = 4
    first: int = 8
    batch: int = 4
    steps: int = 1500
    learning_rate: float = 5e-3
    balance: float = 0.5
    validate_every: int = 100
    validation: float = 0.15
    val_crops: int = 16

    def __post_init__(self) -> None:
        if (
            self.points < self.ratio ** len(self.widths) * 2
            or self.k < 2
            or self.ratio < 2
            or not self.widths
        ):
            raise ConfigError(
                f"RandLA settings: points must leave >= 2 points at the last level "
                f"(points >= 2 * ratio ** layers) and k, ratio >= 2; got {self}"
            )


@dataclass
class _Crop:
    xyz: list[np.ndarray]  # per level (N_l, 3) float32, centred
    nbr: list[np.ndarray]  # per level (N_l, k) int64
    up: list[np.ndarray]  # per level l < L: (N_l,) int64 into level l + 1
    x: np.ndarray  # (N, 3) float32 input: dx, dy, height
    y: np.ndarray  # (N,) int64 labels (-1 unlabelled)
    index: np.ndarray  # (N,) int64 into the scan's points


def crop(
    xyz: np.ndarray,
    height: np.ndarray,
    labels: np.ndarray,
    tree: cKDTree,
    centre: int,
    p: RandLAParams,
    *,
    rng: np.random.Generator,
) -> _Crop:
    """The sample around point ``centre`` of one scan: its ``p.points`` nearest points in a
    random order, with each level's neighbours and the nearest point of the next level."""
    n = min(p.points, len(xyz))
    _, idx = tree.query(xyz[centre], k=n)
    idx = np.atleast_1d(idx).astype(np.int64)
    if n < p.points:  # a small scan: repeats of its own points, as the original pads
        idx = np.concatenate([idx, rng.choice(idx, p.points - n)])
    idx = idx[rng.permutation(p.points)]
    pts = (xyz[idx] - xyz[centre]).astype(np.float32)
    levels, nbrs, ups = [pts], [], []
    for _ in p.widths:
        cur = levels[-1]
        nbrs.append(
            cKDTree(cur).query(cur, k=min(p.k, len(cur)))[1].astype(np.int64).reshape(len(cur), -1)
        )
        nxt = cur[: len(cur) // p.ratio]
        ups.append(cKDTree(nxt).query(cur, k=1)[1].astype(np.int64))
        levels.append(nxt)
    x = np.column_stack([pts[:, :2], height[idx]]).astype(np.float32)
    return _Crop(levels, nbrs, ups, x, labels[idx].astype(np.int64), idx)


def _stack(torch: Any, crops: list[_Crop]) -> dict:
    """A batch of crops as tensors (B, ...)."""
    t = torch.from_numpy
    return {
        "x": t(np.stack([c.x for c in crops])),
        "y": t(np.stack([c.y for c in crops])),
        "xyz": [t(np.stack([c.xyz[l] for c in crops])) for l in range(len(crops[0].xyz))],
        "nbr": [t(np.stack([c.nbr[l] for c in crops])) for l in range(len(crops[0].nbr))],
        "up": [t(np.stack([c.up[l] for c in crops])) for l in range(len(crops[0].up))],
    }


def _net(torch: Any, p: RandLAParams, n_classes: int) -> Any:
    nn = torch.nn

    def gather(f, idx):  # f (B, N, C), idx (B, M, K) -> (B, M, K, C)
        b, m, k = idx.shape
        flat = idx.reshape(b, m * k, 1).expand(-1, -1, f.shape[-1])
        return torch.gather(f, 1, flat).reshape(b, m, k, f.shape[-1])

    class MLP(nn.Module):  # shared: Linear + BatchNorm + LeakyReLU on the last axis
        def __init__(self, cin: int, cout: int, act: bool = True) -> None:
            super().__init__()
            self.lin, self.bn, self.act = nn.Linear(cin, cout), nn.BatchNorm1d(cout), act

        def forward(self, f):
            shape = f.shape
            f = self.bn(self.lin(f).reshape(-1, self.lin.out_features)).reshape(*shape[:-1], -1)
            return nn.functional.leaky_relu(f, 0.2) if self.act else f

    class AttPool(nn.Module):
        def __init__(self, cin: int, cout: int) -> None:
            super().__init__()
            self.score, self.mlp = nn.Linear(cin, cin, bias=False), MLP(cin, cout)

        def forward(self, f):  # (B, N, K, C) -> (B, N, cout)
            return self.mlp((torch.softmax(self.score(f), dim=2) * f).sum(2))

    class Block(nn.Module):  # the dilated residual block
        def __init__(self, cin: int, d: int) -> None:
            super().__init__()
            h = max(d // 2, 1)
            self.mlp1, self.pos1, self.att1 = MLP(cin, h), MLP(10, h), AttPool(2 * h, h)
            self.pos2, self.att2 = MLP(h, h), AttPool(2 * h, d)
            self.mlp2, self.short = MLP(d, 2 * d, act=False), MLP(cin, 2 * d, act=False)

        def forward(self, f, xyz, nbr):
            pk = gather(xyz, nbr)  # (B, N, K, 3)
            pi = xyz.unsqueeze(2).expand_as(pk)
            rel = pi - pk
            r = self.pos1(torch.cat([pi, pk, rel, rel.norm(dim=-1, keepdim=True)], -1))
            g = self.mlp1(f)
            g = self.att1(torch.cat([r, gather(g, nbr)], -1))
            r2 = self.pos2(r)
            g = self.att2(torch.cat([r2, gather(g, nbr)], -1))
            return nn.functional.leaky_relu(self.mlp2(g) + self.short(f), 0.2)

    class Net(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            w = p.widths
            self.fc0 = MLP(3, p.first)
            self.enc = nn.ModuleList()
            cin = p.first
            for d in w:
                self.enc.append(Block(cin, d))
                cin = 2 * d
            self.mid = MLP(cin, cin)
            self.dec = nn.ModuleList()
            for lvl in reversed(range(len(w))):
                cout = 2 * w[max(lvl - 1, 0)]
                self.dec.append(MLP(cin + 2 * w[lvl], cout))
                cin = cout
            self.head = nn.Sequential(
                MLP(cin, 64), MLP(64, 32), nn.Dropout(0.5), nn.Linear(32, n_classes)
            )

        def forward(self, b):
            f = self.fc0(b["x"])
            skips = []
            for lvl, blk in enumerate(self.enc):
                f = blk(f, b["xyz"][lvl], b["nbr"][lvl])
                skips.append(f)
                m = b["xyz"][lvl + 1].shape[1]
                f = gather(f, b["nbr"][lvl][:, :m]).amax(2)  # random sampling + max-pool
            f = self.mid(f)
            for j, lvl in enumerate(reversed(range(len(self.enc)))):
                up = torch.gather(f, 1, b["up"][lvl].unsqueeze(-1).expand(-1, -1, f.shape[-1]))
                f = self.dec[j](torch.cat([up, skips[lvl]], -1))
            return self.head(f)  # (B, N, classes)

    return Net()


class _Scans:
    """The scans of a table with their trees, heights and labels, and the table offset of each."""

    def __init__(self, data: PointTable, keep: np.ndarray) -> None:
        self.items, start = [], 0
        for s in data.scans:
            sl = slice(start, start + len(s))
            start += len(s)
            if keep[sl].any():
                lab = np.where(keep[sl], data.labels[sl], -1).astype(np.int64)
                self.items.append((s.xyz, s.height, lab, cKDTree(s.xyz), sl.start))
        self.weights = np.array([float((it[2] >= 0).sum()) for it in self.items])

    def crops(self, n: int, p: RandLAParams, *, rng: np.random.Generator) -> list[_Crop]:
        """``n`` training crops: a scan in proportion to its labelled points, a labelled centre."""
        out = []
        for i in rng.choice(len(self.items), size=n, p=self.weights / self.weights.sum()):
            xyz, h, lab, tree, _ = self.items[i]
            centre = int(rng.choice(np.flatnonzero(lab >= 0)))
            out.append(crop(xyz, h, lab, tree, centre, p, rng=rng))
        return out


@dataclass
class RandLAModel:
    """RandLA-Net (see the module's docstring)."""

    n_classes: int
    params: RandLAParams = field(default_factory=RandLAParams)
    state: Any = None
    rounds_used: int = 0
    trained_classes: tuple[int, ...] = ()
    curve: list = field(default_factory=list)

    name = "randla"

    def fit(
        self,
        data: PointTable,
        *,
        rng: np.random.Generator,
        threads: int = 1,
        init: "RandLAModel | None" = None,
        progress: bool = False,
    ) -> "RandLAModel":
        """Train on ``data`` (its scans and classes); ``init``: a trained model to start from."""
        torch = _torch()
        torch.set_num_threads(max(1, threads))
        p = self.params
        torch.manual_seed(
            int(rng.integers(2**62))
        )  # initial weights and dropout draw from torch's CPU generator
        net = _net(torch, p, self.n_classes)
        if init is not None:
            net.load_state_dict(init.state)
        y = data.labels
        self.trained_classes = tuple(int(c) for c in np.unique(y[y >= 0]))
        held = split_groups(data.groups, p.validation, rng=rng)
        train = _Scans(data, ~held & (y >= 0))
        if not train.items:
            raise ConfigError("training set: no labelled point for RandLA-Net")
        val = _Scans(data, held & (y >= 0)) if held.any() else None
        val_crops = (
            val.crops(p.val_crops, p, rng=np.random.default_rng(int(rng.integers(2**62))))
            if val
            else []
        )
        counts = np.bincount(y[y >= 0].astype(np.int64), minlength=self.n_classes).astype(
            np.float64
        )
        w = np.where(counts > 0, np.maximum(counts, 1) ** -p.balance, 0.0)
        w = w / w[counts > 0].mean()
        loss_fn = torch.nn.CrossEntropyLoss(
            weight=torch.tensor(w, dtype=torch.float32), ignore_index=-1
        )
        opt = torch.optim.Adam(net.parameters(), lr=p.learning_rate)
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, p.steps)
        per_epoch = max(1.0, float(train.weights.sum()) / (p.batch * p.points))
        best, best_state, bar, t0, loss_sum = -1.0, None, None, time.perf_counter(), 0.0
        self.curve = []
        if progress:
            bar = tqdm(total=p.steps, desc="randla", unit="step", leave=False)
        for step in range(p.steps):
            net.train()
            b = _stack(torch, train.crops(p.batch, p, rng=rng))
            opt.zero_grad()
            out = net(b)
            loss = loss_fn(out.reshape(-1, self.n_classes), b["y"].reshape(-1))
            loss.backward()
            opt.step()
            sched.step()
            loss_sum += float(loss.detach())
            if bar is not None:
                bar.update()
                bar.set_postfix(loss=f"{float(loss):.3f}")
            if (step + 1) % p.validate_every == 0 or step + 1 == p.steps:
                miou = self._score(torch, net, val_crops) if val_crops else float("nan")
                n = (step % p.validate_every) + 1
                self.curve.append(
                    {
                        "step": step + 1,
                        "epoch": (step + 1) / per_epoch,
                        "seconds": time.perf_counter() - t0,
                        "train_loss": loss_sum / n,
                        "val_miou": miou,
                        "load": os.getloadavg()[0],
                    }
                )
                loss_sum = 0.0
                log.info(
                    "randla step %d: loss %.3f, validation mIoU %.3f",
                    step + 1,
                    self.curve[-1]["train_loss"],
                    miou,
                )
                if not val_crops or miou > best:
                    best = miou
                    best_state = {k: t.detach().clone() for k, t in net.state_dict().items()}
                    self.rounds_used = step + 1
        if bar is not None:
            bar.close()
        self.state = best_state if best_state is not None else net.state_dict()
        return self

    def _score(self, torch: Any, net: Any, crops: list[_Crop]) -> float:
        """mIoU over the points of some crops (the classes present in them)."""
        net.eval()
        conf = np.zeros((self.n_classes, self.n_classes), np.int64)
        with torch.no_grad():
            for i in range(0, len(crops), 4):
                part = crops[i : i + 4]
                pred = net(_stack(torch, part)).argmax(-1).numpy()
                for c, pr in zip(part, pred):
                    conf += confusion(c.y, pr, self.n_classes)
        return scores(conf).miou if conf.sum() else float("nan")

    def predict(self, data: PointTable, *, threads: int = 1) -> np.ndarray:
        """(N,) int16 classes of ``data``'s points: crops centred on the least-predicted point
        until every point has been predicted, probabilities summed."""
        if self.state is None:
            raise ConfigError("the model is not trained")
        torch = _torch()
        torch.set_num_threads(max(1, threads))
        p = self.params
        net = _net(torch, p, self.n_classes)
        net.load_state_dict(self.state)
        net.eval()
        out = np.zeros(len(data), np.int16)
        rng = np.random.default_rng(0)
        start = 0
        with torch.no_grad():
            for s in data.scans:
                n = len(s)
                tree, h, lab = cKDTree(s.xyz), s.height, np.zeros(n, np.int64)
                seen = np.zeros(n, np.int64)
                prob = np.zeros((n, self.n_classes), np.float32)
                while True:
                    centre = int(np.argmin(seen))
                    if seen[centre] > 0:
                        break
                    c = crop(s.xyz, h, lab, tree, centre, p, rng=rng)
                    pr = torch.softmax(net(_stack(torch, [c]))[0], -1).numpy()
                    np.add.at(prob, c.index, pr)
                    seen[c.index] += 1
                out[start : start + n] = prob.argmax(1)
                start += n
        return out
