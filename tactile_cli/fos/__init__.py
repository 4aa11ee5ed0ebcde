"""First-order-system fits of press and slip regions (paper 000, sec. 4.2, eqs. 16-17).

A pure array core for ``tactile fit-fos``: padded ``(n_trials, n_points)`` event counts per
bin in, per-trial dataclasses out. The fits run in float64 inside a scoped
``jax.enable_x64(True)`` context; importing this package changes no global JAX setting.
"""

from .fit import FitOptions as FitOptions
from .fit import FitStatus as FitStatus
from .fit import FosFitResult as FosFitResult
from .fit import fit_pulse as fit_pulse
from .fit import fit_ramp as fit_ramp
from .fit import fit_second_order as fit_second_order
from .fit import fit_step as fit_step
from .models import first_order_response as first_order_response
from .models import pulse_response as pulse_response
from .models import ramp_response as ramp_response
from .models import second_order_basis as second_order_basis
from .models import second_order_response as second_order_response
from .models import step_response as step_response
from .models import unit_response as unit_response
from .order import OrderSelection as OrderSelection
from .order import select_order as select_order
