"""xlotkit: simulate and interpret extended leak-off tests (XLOT).

Two halves share one canonical record (:class:`xlotkit.record.Record`):

* :mod:`xlotkit.sim` simulates an XLOT (lumped model and 2D hydro-mechanical MDEM model);
* :mod:`xlotkit.interpret` reads field logs, finds cycles and picks closure and breakdown
  pressures with uncertainties, and turns them into stress estimates.

All quantities are SI inside the package (Pa, m, s, kg, m^3/s); field units appear only in
readers, the command line and plots.
"""

from xlotkit.errors import InputError, XlotkitError
from xlotkit.record import Event, PressureReference, Record

__all__ = ["Event", "InputError", "PressureReference", "Record", "XlotkitError", "__version__"]

__version__ = "0.1.0"
