"""The libraries' warnings about their own internals (OpenMDAO's, Dymos'), kept from the
user: a light module, imported before anything heavy."""

from __future__ import annotations


def quiet_libraries() -> None:
    """OpenMDAO/Dymos warnings about their own internals are noise for a user, in a
    terminal or in a worker's log."""
    import warnings

    for module in ('openmdao', 'dymos'):
        warnings.filterwarnings('ignore', module=module)
    warnings.filterwarnings('ignore', category=DeprecationWarning)
    try:
        from openmdao.utils.om_warnings import OpenMDAOWarning

        warnings.filterwarnings('ignore', category=OpenMDAOWarning)
    except ImportError:  # pragma: no cover
        pass
