"""The sparsity pattern of the reduced (free-DOF, upper-triangular) tangent and the maps of each
term's element entries into it (:class:`.model.Model` assembles with them).

The pattern starts as the solid's couplings and grows by the couplings a later term lacks: the
sheet's and the cavity's facets once, the self-contact's pairs as the shape moves (the linear
solver then analyses the new pattern once; :class:`.model.Model` grows it then by every candidate
pair's couplings, so that pairs meeting later need no new analysis). When it grows, every map already made is moved
along, so each term's entries stay where they were.
"""

from __future__ import annotations

import numpy as np

from . import kernels


class Pattern:
    """CSR pattern (``indices``, ``indptr``, ``diag_pos``) of the reduced tangent, upper triangle,
    and the named maps (``maps[name]``: per element, the position of each of its upper-triangle
    entries in the pattern, -1 for a held dof)."""

    def __init__(self, edofs: np.ndarray, free_index: np.ndarray, nfree: int):
        self.free_index, self.nfree = free_index, nfree
        keys = kernels.pair_keys(edofs, free_index, nfree)
        valid = keys >= 0
        uniq, inverse = np.unique(keys[valid], return_inverse=True)
        kmap = np.full(keys.shape, -1, dtype=np.int32)
        kmap[valid] = inverse
        self.maps: dict[str, np.ndarray] = {"solid": kmap}
        self._set(uniq)

    def _set(self, keys: np.ndarray) -> None:
        """The CSR pattern from its sorted keys ``row * nfree + col``."""
        nfree = self.nfree
        self._keys = keys
        rows = keys // nfree
        self.indices = (keys - rows * nfree).astype(np.int32)
        self.indptr = np.zeros(nfree + 1, dtype=np.int32)
        np.cumsum(np.bincount(rows, minlength=nfree), out=self.indptr[1:])
        self.diag_pos = self.indptr[:-1].astype(np.int64)

    def add(self, name: str, fdofs: np.ndarray) -> np.ndarray:
        """Maps the elements ``fdofs`` (kept as ``maps[name]``, moved along as the pattern grows)."""
        self.maps[name] = self.positions(fdofs)
        return self.maps[name]

    def lacks(self, fdofs: np.ndarray) -> bool:
        """Whether the elements ``fdofs`` couple dofs the pattern does not hold yet."""
        keys = kernels.pair_keys(fdofs, self.free_index, self.nfree)
        pos = np.clip(np.searchsorted(self._keys, keys), 0, self._keys.size - 1)
        return bool(((keys >= 0) & (self._keys[pos] != keys)).any())

    def positions(self, fdofs: np.ndarray) -> np.ndarray:
        """Positions in the pattern of each entry of the elements ``fdofs``; the pattern grows by
        the couplings it lacks, the maps already made moved along."""
        keys = kernels.pair_keys(fdofs, self.free_index, self.nfree)
        pos = np.clip(np.searchsorted(self._keys, keys), 0, self._keys.size - 1)
        missing = (keys >= 0) & (self._keys[pos] != keys)
        if missing.any():
            new = np.unique(keys[missing])  # few: np.union1d would sort the whole pattern again
            grown = np.insert(self._keys, np.searchsorted(self._keys, new), new)
            moved = np.searchsorted(grown, self._keys).astype(np.int32)
            for name, kmap in self.maps.items():
                self.maps[name] = np.where(kmap >= 0, moved[np.maximum(kmap, 0)], -1).astype(np.int32)
            self._set(grown)
            pos = np.searchsorted(self._keys, keys)
        return np.where(keys >= 0, pos, -1).astype(np.int32)
