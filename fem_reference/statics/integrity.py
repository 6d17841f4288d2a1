"""Checks that a converged FE state is one the model may stand behind.

* *Rigid stays rigid*: by default rigid links are exact constraints (``rigid.py``) that
  cannot stretch; a driver beyond the mechanism's reach leaves no equilibrium and the run
  fails (``models.Runner.run`` names the reason).  A returned state whose links are off by
  more than ``LINK_ERROR_MAX`` (relative to the scene's length) is refused.  With the option
  ``rigid_links = "stiff"`` they are stiff corotational elements (``rigid_factor``, relative
  compliance ~1e-6); a link stretched by more than ``RIGID_STRETCH_MAX`` (relative) means the
  scene asks for the impossible -- a driver beyond the mechanism's reach, or loads that only
  the link's artificial axial compliance can carry -- and the run fails with that reason.
* *Moderate strains*: the element's local law is linear in the engineering strain; beyond
  ``STRAIN_MAX`` (20 %: strain measures differ by ~10 % there, and no elastic flexure material
  gets near it; a DAS-2D bistable switch reaches 5 %) the member is outside the model (a tip
  driven to 500 % strain) and the run fails with that reason.
"""

from __future__ import annotations

import numpy as np

from cases.limits import RIGID_STRETCH_MAX, STRAIN_MAX, beyond  # the bounds every model is held to
from fem_reference import corotational as cr

LINK_ERROR_MAX = 1e-9  # exact links: far above round-off, far below any output tolerance


def strains(
    system: object, u: np.ndarray, local: cr.LocalState | None = None
) -> dict[str, tuple[str, float]]:
    """``{member id: (kind, largest |axial strain| of its elements)}`` of state ``u``
    (``local``: the element state of ``u`` when the caller has it)."""
    st = (
        local
        if local is not None
        else cr.local_state(system.beams, system.full(u)[system.beam_dofs])
    )
    eps = np.abs(st.ln / system.beams.L0 - 1.0)
    return {
        m.id: (m.kind, float(np.maximum.reduce(eps[m.elements], initial=0.0)))
        for m in system.members
        if m.kind in ("rigid", "flexible")
    }


def violation(system: object, u: np.ndarray, local: cr.LocalState | None = None) -> str | None:
    """None, or why state ``u`` is outside what the FE model represents (``local``: its
    element state, if known)."""
    if not hasattr(system, "beams") or not hasattr(system, "members"):
        return None
    link = system.max_link_error(u) / system.length_scale()
    if link > LINK_ERROR_MAX:
        return f"rigid links off by {link:.2g} L (bound {LINK_ERROR_MAX:g}): not an equilibrium"
    for mid, (kind, e) in strains(system, u, local).items():
        if kind == "rigid" and beyond(e, RIGID_STRETCH_MAX):
            return (
                f"rigid link {mid!r} stretched by {e:.2g} (bound {RIGID_STRETCH_MAX:g}): the "
                "scene asks for more than its rigid links allow (a driver beyond reach?)"
            )
        if kind == "flexible" and beyond(e, STRAIN_MAX):
            return (
                f"member {mid!r} strained by {e:.2g} (bound {STRAIN_MAX:g}): beyond the "
                "moderate-strain elastic model"
            )
    return None
