"""IPOPT on OpenMDAO problems: exact sparsity from declared structure, colored totals, the
IPOPT driver (public OpenMDAO API; the one module with private names is
:mod:`suspopt.driver.structure`)."""

from suspopt.driver.ipopt import (
    IPOPT_STATUS,
    SUCCESS,
    IpoptDriver,
    IterationInfo,
    ipopt_option_problems,
)

__all__ = ['IPOPT_STATUS', 'SUCCESS', 'IpoptDriver', 'IterationInfo', 'ipopt_option_problems']
