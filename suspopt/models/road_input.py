"""The road-input component: the road height under every wheel at the node times
(docs/roads.md, paper Figure 3)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.road import wheel_road_inputs


class RoadInputComp(om.ExplicitComponent):
    """Road height under every wheel, ``δ_c(t) = r_track(c)(v t - offset_c)`` (docs/roads.md), an
    output of shape (num_nodes, corners).

    The node times are fixed in a study (fixed horizon), so the heights and their time
    derivatives are computed once per distinct time input and then reused."""

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        self.options.declare('tracks', types=tuple, desc='road profile of each wheel track')
        self.options.declare('speed', types=float, desc='vehicle speed [m/s]')
        self.options.declare(
            'offsets', types=tuple, desc='distance of each wheel behind the front axle [m]'
        )
        self.options.declare('track_of', types=tuple, desc='wheel track of each corner')

    def setup(self) -> None:
        nn, nc = self.options['num_nodes'], len(self.options['offsets'])
        self.add_input('time', shape=(nn,), units='s')
        self.add_output('delta', shape=(nn, nc), units='m', desc='road height under each wheel')
        self.declare_partials(
            'delta', 'time', rows=np.arange(nn * nc), cols=np.repeat(np.arange(nn), nc)
        )
        self._memo: tuple[bytes, np.ndarray, np.ndarray] | None = None

    def heights(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Heights and rates (num_nodes, corners) at node times ``t``."""
        key = np.ascontiguousarray(t).tobytes()
        memo = getattr(self, '_memo', None)
        if memo is None or memo[0] != key:
            o = self.options
            h = np.empty((t.size, len(o['offsets'])))
            dh = np.empty_like(h)
            for k, road in enumerate(o['tracks']):
                cols = [c for c, tr in enumerate(o['track_of']) if tr == k]
                if cols:
                    hk, dk = wheel_road_inputs(
                        road, t, o['speed'], tuple(o['offsets'][c] for c in cols)
                    )
                    h[:, cols], dh[:, cols] = hk.T, dk.T
            memo = self._memo = (key, h, dh)
        return memo[1], memo[2]

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The road heights at the node times (the vehicle assembly's equation)."""
        return {'delta': self.heights(np.asarray(inputs['time']).ravel())[0]}

    def compute(self, inputs, outputs) -> None:
        outputs['delta'] = self.evaluate(inputs)['delta']

    def compute_partials(self, inputs, partials) -> None:
        partials['delta', 'time'] = self.heights(inputs['time'])[1].ravel()
