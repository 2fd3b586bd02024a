"""One interrupt protocol (suspopt.interrupts): no solve can ignore a signal.

* a signal during a model evaluation stops IPOPT before its next evaluation (the old
  driver only looked between iterations, and cyipopt swallowed a second Ctrl-C raised
  inside a callback: the iteration, however long, ran on);
* a signal held while a solve is prepared stops the sparsity and coloring at once;
* after the first signal a second one ends the process at once, even while the main
  thread is inside C code that never returns to Python;
* every IPOPT solve has a wall-time guard.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import openmdao.api as om
import pytest

from suspopt import interrupts
from suspopt.driver import IpoptDriver


class Paraboloid(om.ExplicitComponent):
    """f = (x-3)² + xy + (y+4)² - 3 (minimum at x = 20/3, y = -22/3); counts its calls and
    sends SIGINT to this process from inside its ``signal_at``-th evaluation."""

    def initialize(self):
        self.options.declare('signal_at', default=0)
        self.computes = self.partials = 0
        self.partials_after_signal = 0
        self.signalled = False

    def setup(self):
        self.add_input('x', 0.0)
        self.add_input('y', 0.0)
        self.add_output('f', 0.0)
        self.declare_partials('*', '*')

    def compute(self, inputs, outputs):
        self.computes += 1
        x, y = inputs['x'][0], inputs['y'][0]
        outputs['f'] = (x - 3.0) ** 2 + x * y + (y + 4.0) ** 2 - 3.0
        if self.computes == self.options['signal_at']:
            self.signalled = True
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of an evaluation

    def compute_partials(self, inputs, J):
        self.partials += 1
        self.partials_after_signal += self.signalled
        x, y = inputs['x'][0], inputs['y'][0]
        J['f', 'x'] = 2.0 * (x - 3.0) + y
        J['f', 'y'] = x + 2.0 * (y + 4.0)


def _problem(signal_at: int = 0) -> tuple[om.Problem, Paraboloid]:
    p = om.Problem(reports=False)
    comp = p.model.add_subsystem('comp', Paraboloid(signal_at=signal_at), promotes=['*'])
    p.model.add_design_var('x', lower=-50.0, upper=50.0)
    p.model.add_design_var('y', lower=-50.0, upper=50.0)
    p.model.add_objective('f')
    p.driver = IpoptDriver()
    p.setup()
    return p, comp


def test_a_signal_during_a_model_evaluation_stops_ipopt_before_its_next_evaluation():
    p, comp = _problem()
    p.run_driver()
    full = comp.computes
    assert p.driver.status == 0 and full > 4
    p, comp = _problem(signal_at=3)
    with interrupts.handling():
        p.run_driver()
        assert interrupts.requested()
    assert comp.signalled and p.driver.interrupted
    assert p.driver.status_message == 'User_Requested_Stop'
    # no derivative and one model run only (IPOPT's final point, for the record) after it
    assert comp.partials_after_signal == 0
    assert comp.computes == 3 + 1 < full


def test_a_held_signal_stops_the_coloring_at_once():
    """The sparsity and coloring of a solve run inside the hold that protects its
    result; a signal there stops them at once (nothing is computed yet)."""
    from suspopt.driver.sparsity import compute_coloring

    p, _ = _problem()
    p.final_setup()
    lay = p.driver.layout()
    with pytest.raises(KeyboardInterrupt), interrupts.hold():
        os.kill(os.getpid(), signal.SIGINT)
        assert interrupts.requested()  # held, not raised
        compute_coloring(p, lay.constraints + [lay.objective], lay.design_vars)


def test_a_second_signal_ends_the_process_inside_c_code(tmp_path):
    """A first SIGINT is held while the main thread is busy in LAPACK (the interpreter's
    handler cannot run before it returns); the second ends the process at once (the
    watchdog, told of both by the interpreter's C-level handler, kills it)."""
    script = textwrap.dedent(
        """
        import sys, numpy as np
        from suspopt import interrupts
        a = np.random.default_rng(0).random((1500, 1500))
        with interrupts.hold():
            print('ready', flush=True)
            for _ in range(10_000):
                np.linalg.eigvals(a)  # seconds in LAPACK, never in Python
        print('not reached', flush=True)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, '-c', script],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, 'OMP_NUM_THREADS': '1', 'OPENBLAS_NUM_THREADS': '1'},
    )
    try:
        assert proc.stdout.readline().strip() == 'ready'
        proc.send_signal(signal.SIGINT)
        time.sleep(0.3)
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
        waited = time.perf_counter() - t0
    finally:
        proc.kill()
    assert proc.returncode in (-signal.SIGKILL, -signal.SIGINT), proc.returncode
    assert waited < 2.0, waited


def test_every_ipopt_solve_has_a_wall_time_guard():
    from suspopt.driver.ipopt import MAX_WALL_TIME

    p, _ = _problem()
    p.final_setup()
    p.driver.prepare()
    assert p.driver._ipopt_options()['max_wall_time'] == MAX_WALL_TIME
    p.driver.opt_settings['max_wall_time'] = 1e-9  # a study's options override it
    p.run_driver()
    assert p.driver.status_message == 'Maximum_WallTime_Exceeded'
    assert np.isfinite(p.get_val('f')[0])
