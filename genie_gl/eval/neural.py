"""A small neural point model, trained and run on the CPU with PyTorch (``pip install
'genie-gl[neural]'``): DGCNN-style edge convolutions (Wang et al. 2019) on a fixed k-nearest-
neighbour graph, with a tile-wide max-pooled context.

Each scan is cut into square tiles of ``tile_m`` (a tile of more than ``max_points`` points is
split into random subsets of at most that many, so the graph's density is the same in training
and prediction). A point's input is its offset from the tile's centre in x and y and its height
above the floor; three edge convolutions (``MLP([f_i, f_j - f_i])``, max over the k neighbours)
give per-point features, their max over the tile gives the context, and a point-wise MLP the
class scores. Training: Adam, cross-entropy weighted by ``(n_c) ** -balance``, tiles turned at
random about z, a fixed number of steps whatever the data size (so the epochs scale with it),
the weights with the lowest loss on the validation scenes kept (the paper's "best checkpoint").
Weights, tiles and batches come from the seed; with the same thread count the same seed gives
the same bytes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

import pgeof
from tqdm import tqdm

from ..errors import ConfigError
from .classical import split_groups
from .features import PointTable

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class NeuralParams:
    """Settings of the neural model."""

    tile_m: float = 4.0
    max_points: int = 1536
    k: int = 10
    width: int = 16
    steps: int = 300
    batch_tiles: int = 4
    learning_rate: float = 2e-3
    balance: float = 0.5
    validate_every: int = 100
    validation: float = 0.15


def _torch():
    try:
        import torch
    except ImportError:
        raise ConfigError(
            "the neural model needs PyTorch: pip install 'genie-gl[neural]' "
            "(the CPU build, torch==2.13.0)"
        ) from None
    return torch


def tiles(
    xy: np.ndarray, tile_m: float, max_points: int, *, rng: np.random.Generator
) -> list[np.ndarray]:
    """Point indices of the tiles of one scan: a grid of ``tile_m`` squares anchored at the
    scan's minimum, a crowded tile split into random subsets of at most ``max_points``."""
    ij = np.floor((xy - xy.min(0)) / tile_m).astype(np.int64)
    key = ij[:, 0] * (int(ij[:, 1].max()) + 1) + ij[:, 1]
    order = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.diff(key[order])) + 1
    out = []
    for part in np.split(order, bounds):
        if len(part) > max_points:
            part = rng.permutation(part)
            n = -(-len(part) // max_points)
            out.extend(np.sort(p) for p in np.array_split(part, n))
        else:
            out.append(part)
    return out


def _net(torch: Any, width: int, n_classes: int) -> Any:
    nn = torch.nn

    class Edge(nn.Module):
        def __init__(self, cin: int, cout: int) -> None:
            super().__init__()
            self.mlp = nn.Sequential(
                nn.Linear(2 * cin, cout),
                nn.LeakyReLU(0.2),
                nn.Linear(cout, cout),
                nn.LeakyReLU(0.2),
            )

        def forward(self, f, nbr):
            fj = f[nbr]  # (N, k, C)
            fi = f.unsqueeze(1).expand_as(fj)
            return self.mlp(torch.cat([fi, fj - fi], -1)).amax(1)

    class Net(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            w = width
            self.e1, self.e2, self.e3 = Edge(3, w), Edge(w, w), Edge(w, 2 * w)
            self.point = nn.Sequential(nn.Linear(4 * w, 4 * w), nn.LeakyReLU(0.2))
            self.head = nn.Sequential(
                nn.Linear(8 * w, 4 * w),
                nn.LeakyReLU(0.2),
                nn.Linear(4 * w, 2 * w),
                nn.LeakyReLU(0.2),
                nn.Linear(2 * w, n_classes),
            )

        def forward(self, x, nbr, tile, n_tiles):
            f1 = self.e1(x, nbr)
            f2 = self.e2(f1, nbr)
            f3 = self.e3(f2, nbr)
            p = self.point(torch.cat([f1, f2, f3], 1))
            ctx = torch.full((n_tiles, p.shape[1]), -1e9, dtype=p.dtype)
            ctx = ctx.scatter_reduce(
                0, tile.unsqueeze(1).expand_as(p), p, "amax", include_self=True
            )
            return self.head(torch.cat([p, ctx[tile]], 1))

    return Net()


@dataclass
class _Tile:
    x: np.ndarray  # (n, 3) float32: dx, dy, height
    nbr: np.ndarray  # (n, k) int64, tile-local
    y: np.ndarray  # (n,) int64
    index: np.ndarray  # (n,) int64 into the table's points


def _make_tiles(
    data: PointTable, which: np.ndarray | None, p: NeuralParams, *, rng: np.random.Generator
) -> list[_Tile]:
    out, start = [], 0
    for scan in data.scans:
        n = len(scan)
        sl = slice(start, start + n)
        start += n
        if which is not None and not which[sl].any():
            continue
        h = scan.height
        for idx in tiles(scan.xyz[:, :2], p.tile_m, p.max_points, rng=rng):
            if which is not None:
                idx = idx[which[sl][idx]]
            if len(idx) == 0:
                continue
            xy = scan.xyz[idx, :2]
            c = (xy.min(0) + xy.max(0)) / 2
            x = np.column_stack([xy - c, h[idx]]).astype(np.float32)
            k = min(p.k, len(idx))
            nbr, _ = pgeof.knn_search(
                np.ascontiguousarray(scan.xyz[idx]), np.ascontiguousarray(scan.xyz[idx]), k
            )
            nbr = nbr.astype(np.int64)
            if k < p.k:
                nbr = np.concatenate([nbr, np.repeat(nbr[:, -1:], p.k - k, 1)], 1)
            out.append(_Tile(x, nbr, data.labels[sl][idx].astype(np.int64), idx + sl.start))
    return out


def _batch(torch: Any, batch: list[_Tile], angle: np.ndarray | None = None):
    xs, nbrs, tile_ids, ys, off = [], [], [], [], 0
    for t, tile in enumerate(batch):
        x = tile.x
        if angle is not None:
            c, s = np.cos(angle[t]), np.sin(angle[t])
            x = x.copy()
            x[:, :2] = x[:, :2] @ np.array([[c, -s], [s, c]], np.float32).T
        xs.append(x)
        nbrs.append(tile.nbr + off)
        tile_ids.append(np.full(len(x), t, np.int64))
        ys.append(tile.y)
        off += len(x)
    return (
        torch.from_numpy(np.concatenate(xs)),
        torch.from_numpy(np.concatenate(nbrs)),
        torch.from_numpy(np.concatenate(tile_ids)),
        torch.from_numpy(np.concatenate(ys)),
    )


@dataclass
class NeuralModel:
    """The DGCNN-style model (see the module's docstring)."""

    n_classes: int
    params: NeuralParams = NeuralParams()
    state: Any = None
    rounds_used: int = 0
    trained_classes: tuple[int, ...] = ()

    name = "neural"

    def fit(
        self,
        data: PointTable,
        *,
        rng: np.random.Generator,
        threads: int = 1,
        init: "NeuralModel | None" = None,
        progress: bool = False,
    ) -> "NeuralModel":
        """Train on ``data`` (its scans and classes); ``init``: a trained model to start from."""
        torch = _torch()
        torch.set_num_threads(max(1, threads))
        p = self.params
        gen = torch.Generator().manual_seed(int(rng.integers(2**62)))
        torch.manual_seed(
            int(rng.integers(2**62))
        )  # parameter initialisation draws from the default generator
        net = _net(torch, p.width, self.n_classes)
        if init is not None:
            net.load_state_dict(init.state)
        y = data.labels
        self.trained_classes = tuple(int(c) for c in np.unique(y[y >= 0]))
        held = split_groups(data.groups, p.validation, rng=rng)
        train_tiles = [t for t in _make_tiles(data, ~held & (y >= 0), p, rng=rng) if len(t.y)]
        val_tiles = (
            [t for t in _make_tiles(data, held & (y >= 0), p, rng=rng) if len(t.y)]
            if held.any()
            else []
        )
        if not train_tiles:
            raise ConfigError("training set: no labelled point for the neural model")
        counts = np.bincount(y[y >= 0].astype(np.int64), minlength=self.n_classes).astype(
            np.float64
        )
        w = np.where(counts > 0, np.maximum(counts, 1) ** -p.balance, 0.0)
        w = w / w[counts > 0].mean()
        loss_fn = torch.nn.CrossEntropyLoss(weight=torch.tensor(w, dtype=torch.float32))
        opt = torch.optim.Adam(net.parameters(), lr=p.learning_rate)
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, p.steps)
        best, best_state, bar = np.inf, None, None
        if progress:
            bar = tqdm(total=p.steps, desc="neural", unit="step", leave=False)
        for step in range(p.steps):
            net.train()
            pick = torch.randint(len(train_tiles), (p.batch_tiles,), generator=gen).numpy()
            angle = torch.rand(p.batch_tiles, generator=gen).numpy() * 2 * np.pi
            batch = [train_tiles[i] for i in pick]
            x, nbr, tile, yy = _batch(torch, batch, angle)
            opt.zero_grad()
            loss = loss_fn(net(x, nbr, tile, len(batch)), yy)
            loss.backward()
            opt.step()
            sched.step()
            if bar is not None:
                bar.update()
                bar.set_postfix(loss=f"{float(loss):.3f}")
            if val_tiles and ((step + 1) % p.validate_every == 0 or step + 1 == p.steps):
                v = self._loss(torch, net, val_tiles, loss_fn)
                if v < best:
                    best, best_state = (
                        v,
                        {k: t.detach().clone() for k, t in net.state_dict().items()},
                    )
                    self.rounds_used = step + 1
        if bar is not None:
            bar.close()
        if best_state is None:
            best_state, self.rounds_used = net.state_dict(), p.steps
        self.state = best_state
        return self

    def _loss(self, torch: Any, net: Any, val_tiles: list[_Tile], loss_fn: Any) -> float:
        net.eval()
        total, n = 0.0, 0
        with torch.no_grad():
            for i in range(0, len(val_tiles), 16):
                batch = val_tiles[i : i + 16]
                x, nbr, tile, yy = _batch(torch, batch)
                total += float(loss_fn(net(x, nbr, tile, len(batch)), yy)) * len(yy)
                n += len(yy)
        return total / max(n, 1)

    def predict(self, data: PointTable, *, threads: int = 1) -> np.ndarray:
        """(N,) int16 classes of ``data``'s points (tiles cut with a generator of fixed seed)."""
        if self.state is None:
            raise ConfigError("the model is not trained")
        torch = _torch()
        torch.set_num_threads(max(1, threads))
        net = _net(torch, self.params.width, self.n_classes)
        net.load_state_dict(self.state)
        net.eval()
        out = np.zeros(len(data), np.int16)
        all_tiles = _make_tiles(data, None, self.params, rng=np.random.default_rng(0))
        with torch.no_grad():
            for i in range(0, len(all_tiles), 16):
                batch = all_tiles[i : i + 16]
                x, nbr, tile, _ = _batch(torch, batch)
                pred = net(x, nbr, tile, len(batch)).argmax(1).numpy().astype(np.int16)
                out[np.concatenate([t.index for t in batch])] = pred
        return out
