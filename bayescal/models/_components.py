"""The spectral components of a noise model: each term's fixed shapes of the increments'
spectrum, with their weights (:meth:`~bayescal.models.effects._base.NoiseTerm.components`).

A record's likelihoods take the expected periodogram (:mod:`._whittle`) and the block-mean
covariance (:mod:`._level`) of every component once, and at each draw only the weights.
:class:`Components` lists a family of terms' components in one order that the summaries and
the weights share; the output filter's one-tap term splits the white noise into a lag-zero
and a lag-one component, so that N keeps its meaning.
"""

import dataclasses
import functools

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _x64  # noqa: F401  (float64 before any JAX array)
from ._terms import NOISE_TERMS, TERMS
from .effects._parameter import Context
from .effects.white import White


class Components(eqx.Module):
    """The components of the terms ``names`` (those with any) for a record, in the registry's
    order."""

    terms: tuple = eqx.field(static=True)
    """The terms with components, in order."""
    shapes: tuple = eqx.field(static=True)
    """Every component, the terms' in turn: objects with ``autocovariance``, ``spectrum``,
    ``block_covariance`` and ``long_memory``."""
    counts: tuple[int, ...] = eqx.field(static=True)
    """How many components each term has."""

    @functools.cached_property
    def _signature(self) -> tuple:
        """What the components are, as plain values: a shape is a class or a module of
        numbers (a Gauss-Markov node's correlation time)."""
        return (
            self.terms,
            self.counts,
            tuple(
                shape
                if isinstance(shape, type)
                else (type(shape), *(getattr(shape, f.name) for f in dataclasses.fields(shape)))
                for shape in self.shapes
            ),
        )

    # Compared and hashed at every compiled call (its arguments' static structure is the
    # cache's key): equinox's field-by-field comparison of some sixty shapes took 3 ms a
    # call, a tenth of a later fit.
    def __eq__(self, other) -> bool:
        return self is other or (
            isinstance(other, Components) and self._signature == other._signature
        )

    def __hash__(self) -> int:
        return hash(self._signature)

    @classmethod
    def of(cls, names, context: Context) -> "Components":
        """The components of the terms ``names`` (registry names) for a record."""
        wanted = set(names)
        terms, shapes, counts = [], [], []
        for term in NOISE_TERMS:
            parts = term.components(context) if term.name in wanted else ()
            if parts:
                terms.append(term)
                shapes += parts
                counts.append(len(parts))
        return cls(tuple(terms), tuple(shapes), tuple(counts))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(term.name for term in self.terms)

    def restricted(self, names) -> tuple["Components", np.ndarray]:
        """The components of the terms ``names`` among these, and the indices of their rows
        in a summary of these: a model of those terms weighs every other component zero."""
        wanted = set(names)
        keep = [i for i, term in enumerate(self.terms) if term.name in wanted]
        rows = [np.arange(len(self.shapes))[self.slice_of(self.terms[i].name)] for i in keep]
        shapes = tuple(
            shape for i in keep for shape in self.shapes[self.slice_of(self.terms[i].name)]
        )
        restricted = Components(
            tuple(self.terms[i] for i in keep), shapes, tuple(self.counts[i] for i in keep)
        )
        return restricted, np.concatenate(rows) if rows else np.zeros(0, dtype=int)

    def slice_of(self, name: str) -> slice:
        """Where the components of term ``name`` lie."""
        index = self.names.index(name)
        start = sum(self.counts[:index])
        return slice(start, start + self.counts[index])

    @property
    def white(self) -> int:
        """The index of the white noise's component (the rounding floor's too)."""
        return self.slice_of(White.name).start

    @property
    def shaped(self) -> np.ndarray:
        """Indices of the components an output filter's low-pass shapes: the white noise's
        two (its lag-zero and the one-tap filter's lag-one part)."""
        indices = [
            np.arange(len(self.shapes))[self.slice_of(name)]
            for name in self.names
            if TERMS[name].filtered
        ]
        return np.concatenate(indices) if indices else np.zeros(0, dtype=int)

    def weights(self, values: dict):
        """(..., components): each component's weight at ``values`` (parameters by name;
        arrays broadcast); zero for a term whose parameters ``values`` lacks."""
        # The batch of draws is that of these terms' parameters (a line's are per line).
        batch = jnp.broadcast_shapes(
            *(
                jnp.shape(values[p.name])
                for t in self.terms
                for p in t.parameters
                if p.name in values
            )
        )
        parts = []
        for term, count in zip(self.terms, self.counts, strict=True):
            present = all(p.name in values for p in term.parameters)
            part = (
                term.weights(values, self.shapes[self.slice_of(term.name)])
                if present
                else jnp.zeros(count)
            )
            parts.append(jnp.broadcast_to(part, (*batch, count)))
        return jnp.concatenate(parts, axis=-1)

    def increment_spectra(self, nu, rate_hz: float) -> jnp.ndarray:
        """(..., components): each component's two-sided spectrum of the increments per unit
        weight at ``nu`` cycles per sample."""
        return jnp.stack([shape.spectrum(nu, rate_hz) for shape in self.shapes], axis=-1)

    def increment_autocovariances(self, lags, rate_hz: float) -> np.ndarray:
        """(components, lags): each component's autocovariance of the increments per unit
        weight at integer ``lags`` (numpy)."""
        lags = np.abs(np.asarray(lags, dtype=float))
        return np.stack([np.asarray(shape.autocovariance(lags, rate_hz)) for shape in self.shapes])

    def block_covariances(self, start: np.ndarray, stop: np.ndarray, rate_hz: float) -> np.ndarray:
        """(components, blocks, blocks): covariance of the means of samples [start, stop) per
        unit weight of each component, the nonstationary terms started at sample 0."""
        return np.stack([shape.block_covariance(start, stop, rate_hz) for shape in self.shapes])
