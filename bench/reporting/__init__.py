"""bench/report.py's sections, a module each (see bench/report.py).

The plots are drawn off screen: the backend is chosen here, before any
module loads pyplot."""

import matplotlib

matplotlib.use("Agg")
