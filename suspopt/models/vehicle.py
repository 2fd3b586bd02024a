"""The vehicle model as a Dymos ODE (paper §3.1 and §3.3): an OpenMDAO group built from
the vehicle assembly (:mod:`suspopt.models.assembly`), one subsystem per block.

Node-wise inputs (Dymos targets): ``time``; the states of the assembly; the design
variables (static). Outputs: the states' rates, the objective's integrands ``dJ_dt`` and
every other signal of the assembly (forces, the road, the chassis above each corner).
"""

from __future__ import annotations

import openmdao.api as om

from suspopt.models.assembly import VehicleAssembly


class VehicleODE(om.Group):
    """The ODE of one vehicle model in one scenario (low or mixed fidelity)."""

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        # not in the case recorder's metadata: it holds the multibody modules (their kept
        # poses and tables), megabytes per system and per setup, which nothing reads back
        self.options.declare('assembly', types=VehicleAssembly, recordable=False)

    def setup(self) -> None:
        nn = self.options['num_nodes']
        for block in self.options['assembly'].blocks:
            self.add_subsystem(
                block.name,
                block.make(nn),
                promotes_inputs=[*block.inputs, '*'],
                promotes_outputs=[*block.outputs, '*'],
            )
