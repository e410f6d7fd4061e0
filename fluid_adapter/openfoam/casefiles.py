"""The OpenFOAM dictionaries and initial fields of a moving-plate case, as Python data.

pimpleFoam of v1912 runs dynamic meshes itself (``constant/dynamicMeshDict``). Mesh motion:
``velocityLaplacian`` (incremental) with a saturating plate-distance diffusivity read from a file
(see motion.py for why; docs/openfoam.md gives the measured quality at +-40 mm).
Loads: the ``wallShearStress`` function object and raw ``surfaces`` sampling of p and the wall
shear stress on each plate patch every step (face centres of the moved mesh + values); a
``forces`` function object gives the integrated force as an independent check. Output is binary.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fsi_orchestrator.case.schema import TimeScheme, Turbulence

DIFFUSIVITY_FILE = "plateDiffusivity"  # constant/<this>: written by motion.py
SAMPLE_FO = "interfaceSamples"
FORCES_FO = "fishForces"
HANDSHAKE_FO = "handshake"


@dataclass(frozen=True, kw_only=True)
class FlowSettings:
    """What the case dictionaries depend on."""

    nu_m2_s: float
    rho_kg_m3: float
    turbulence: Turbulence
    time_scheme: TimeScheme
    body_patches: tuple[str, ...]
    wall_patches: tuple[str, ...]
    open_patches: tuple[str, ...]  # p = 0 openings
    # a flume (inflow > 0): uniform inflow along +x through the inlet, p = 0 at the outlet, the
    # wall and open patches slip (flume_fields)
    inflow_m_s: float = 0.0
    inlet_patches: tuple[str, ...] = ()
    outlet_patches: tuple[str, ...] = ()
    moving: bool = True
    n_outer: int = 2
    n_non_orthogonal: int = 1
    # transient p (and pFinal) tolerance, normalized residual; pcorr's is 1e-3 (fv_solution)
    p_tolerance: float = 1e-6
    max_courant: float = 2.0
    # velocityLaplacian diffusivity tokens: the plate-distance file (motion.py) by default;
    # e.g. ("quadratic", "inverseDistance", ["flag"]) for a small-motion 2D case
    motion_diffusivity: tuple = ("file", DIFFUSIVITY_FILE)


# digits of a time folder's name (OpenFOAM adds digits on its own where two steps' names would
# clash, and a restart then looks for the shorter name: turek_hron.cfd3.continue_cfd3)
TIME_PRECISION = 15


def control_dict(
    s: FlowSettings, *, start: float, end: float, dt: float, write_every: int = 1
) -> dict:
    return {
        "application": "pimpleFoam",
        "startFrom": "startTime",
        "stopAt": "endTime",
        "purgeWrite": 0,
        "writeFormat": "binary",
        "writePrecision": 12,
        "writeCompression": False,
        "timeFormat": "general",
        "timePrecision": TIME_PRECISION,
        "runTimeModifiable": False,
        **window_controls(s, start=start, end=end, dt=dt, write_every=write_every),
    }


def window_controls(
    s: FlowSettings, *, start: float, end: float, dt: float, write_every: int = 1
) -> dict:
    """The controlDict entries a launch sets: times, and the fluid step. Each coupling window
    of length ``dt`` is split into as many fluid steps as ``max_courant`` needs; output and the
    load sampling happen exactly at window ends (``adjustableRunTime``)."""
    return {
        "startTime": start,
        "endTime": end,
        "deltaT": dt,
        "adjustTimeStep": True,
        "maxCo": s.max_courant,
        "maxDeltaT": dt,
        "writeControl": "adjustableRunTime",
        "writeInterval": dt * write_every,
        "functions": window_functions(s, dt),
    }


def window_functions(s: FlowSettings, dt: float) -> dict:
    """Loads are sampled after every fluid step (a window's loads are their time average)."""
    return {
        "wallShear": {
            "type": "wallShearStress",
            "libs": ["fieldFunctionObjects"],
            "patches": list(s.body_patches),
            "executeControl": "timeStep",
            "executeInterval": 1,
            "writeControl": "writeTime",
            "log": False,
        },
        SAMPLE_FO: _surfaces(s.body_patches),
        FORCES_FO: {
            "type": "forces",
            "libs": ["forces"],
            "patches": list(s.body_patches),
            "rho": "rhoInf",
            "rhoInf": s.rho_kg_m3,
            "CofR": [0, 0, 0],
            # adjustableRunTime: also makes the fluid steps land on every window end
            "writeControl": "adjustableRunTime",
            "writeInterval": dt,
            "log": False,
        },
    }


def handshake_function(command: str) -> dict:
    """``systemCall`` after every fluid step (blocks until ``command`` returns); not at
    start-up (v1912's functionObjectList::start() only reads)."""
    return {
        "type": "systemCall",
        "libs": ["utilityFunctionObjects"],
        "executeCalls": [command],
        "writeCalls": [],
        "endCalls": [],
        "executeControl": "timeStep",
        "executeInterval": 1,
    }


def _surfaces(patches: Sequence[str]) -> dict:
    return {
        "type": "surfaces",
        "libs": ["sampling"],
        "surfaceFormat": "raw",
        "fields": ["p", "wallShearStress"],
        "interpolationScheme": "cell",
        "writeControl": "timeStep",
        "writeInterval": 1,
        "surfaces": {
            name: {"type": "patch", "patches": [name], "interpolate": False, "triangulate": False}
            for name in patches
        },
    }


def _w(text: str) -> tuple | str:
    """A multi-word entry ("Gauss linear") as the token tuple foamlib writes unquoted."""
    words = tuple(_number(w) for w in text.split())
    return words if len(words) > 1 else text


def _number(word: str) -> str | int:
    return int(word) if word.isdigit() else word


def fv_schemes(s: FlowSettings, steady: bool = False) -> dict:
    ddt = "steadyState" if steady else s.time_scheme.value
    bounded = "bounded " if steady else ""
    # k and omega upwind when transient: one fluid step per coupling window puts the rim cells
    # at Courant 2-8, where limitedLinear's implicit weights leave the k/omega matrices without
    # diagonal dominance; their Gauss-Seidel solves then diverged (final residual 1e21, omega
    # 1e55 in a fifth of the cells, frozen after: default level at 18 mm, coarse at 35 mm and
    # 20 windows per period). Upwind: no bounding, forces equal to 1e-4 (docs/openfoam.md).
    turbulence = f"{bounded}Gauss limitedLinear 1" if steady else "Gauss upwind"
    return {
        "ddtSchemes": {"default": ddt},
        "gradSchemes": {"default": _w("Gauss linear")},
        "divSchemes": {
            "default": "none",
            "div(phi,U)": _w(f"{bounded}Gauss linearUpwind grad(U)"),
            "div(phi,k)": _w(turbulence),
            "div(phi,omega)": _w(turbulence),
            "div((nuEff*dev2(T(grad(U)))))": _w("Gauss linear"),
        },
        "laplacianSchemes": {"default": _w("Gauss linear corrected")},
        "interpolationSchemes": {"default": "linear"},
        "snGradSchemes": {"default": "corrected"},
        "wallDist": {"method": "meshWave"},
    }


def fv_solution(s: FlowSettings, steady: bool = False) -> dict:
    # Tolerances: p in m2/s2 (kinematic, |p| ~ 0.1-1 here), mesh velocity in m/s (|v| < 1);
    # 1e-8 m/s of mesh velocity moves a point 1e-10 m per step.
    # Transient p to 1e-6 (the fish's tank: 1e-5, tankcase.flow_settings) and pcorr
    # (correctPhi's flux projection after the mesh moved, from zero every step) to 1e-3
    # instead of 1e-7 / 1e-5: the fish's forces on a prescribed
    # motion change by 3e-6 of their largest value (default level; thrust 2e-6) while a step
    # costs 22 % less (1.51 -> 1.17 s; pcorr took 100 GAMG iterations, 1 s of a relaunch).
    # correctPhi itself stays: without it the forces were 6 % lower (docs/openfoam.md).
    smooth = {"solver": "smoothSolver", "smoother": "symGaussSeidel", "tolerance": 1e-9}
    p = {
        "solver": "GAMG",
        "smoother": "GaussSeidel",
        "tolerance": 1e-7 if steady else s.p_tolerance,
    }
    p["relTol"] = 0.01
    solvers = {
        "p": p,
        "pFinal": {**p, "relTol": 0},
        '"pcorr.*"': {**p, "tolerance": 1e-3, "relTol": 0},
        '"(U|k|omega)"': {**smooth, "relTol": 0.1},
        '"(U|k|omega)Final"': {**smooth, "relTol": 0},
        '"cellMotionU.*"': {**p, "tolerance": 1e-8, "relTol": 0},
    }
    if steady:
        return {
            "solvers": solvers,
            "SIMPLE": {
                "nNonOrthogonalCorrectors": 0,
                "consistent": True,
                "residualControl": {"p": 1e-7, "U": 1e-8},
            },
            "relaxationFactors": {"equations": {"U": 0.9, '".*"': 0.9}, "fields": {"p": 1.0}},
        }
    return {
        "solvers": solvers,
        "PIMPLE": {
            "momentumPredictor": True,
            "nOuterCorrectors": s.n_outer,
            "nCorrectors": 2,
            "nNonOrthogonalCorrectors": s.n_non_orthogonal,
            "correctPhi": s.moving,
            "moveMeshOuterCorrectors": False,
        },
    }


def dynamic_mesh_dict(s: FlowSettings) -> dict:
    return {
        "dynamicFvMesh": "dynamicMotionSolverFvMesh",
        "motionSolverLibs": ["fvMotionSolvers"],
        "motionSolver": "velocityLaplacian",
        "velocityLaplacianCoeffs": {"diffusivity": s.motion_diffusivity},
    }


def transport_properties(s: FlowSettings) -> dict:
    return {"transportModel": "Newtonian", "nu": s.nu_m2_s}


# both compute k algebraically from the resolved velocity (the k file they get is not read)
LES_MODELS = (Turbulence.SMAGORINSKY, Turbulence.WALE)


def turbulence_properties(s: FlowSettings) -> dict:
    if s.turbulence is Turbulence.LAMINAR:
        return {"simulationType": "laminar"}
    if s.turbulence in LES_MODELS:
        return {
            "simulationType": "LES",
            "LES": {
                "LESModel": s.turbulence.value,
                "turbulence": True,
                "printCoeffs": True,
                "delta": "cubeRootVol",
                "cubeRootVolCoeffs": {"deltaCoeff": 1},
            },
        }
    return {
        "simulationType": "RAS",
        "RAS": {"RASModel": "kOmegaSST", "turbulence": True, "printCoeffs": True},
    }


# --------------------------------------------------------------------------- initial fields
K0 = 1e-6  # m2/s2, quiescent tank (1 mm/s fluctuations)
OMEGA0 = 10.0  # 1/s: nut = k/omega = 1e-7, well below nu


def initial_fields(s: FlowSettings) -> dict[str, dict]:
    """{file name: field file entries} for the 0/ folder."""
    zero_v, wall_v = [0.0, 0.0, 0.0], {"type": "noSlip"}
    body_u = {"type": "movingWallVelocity", "value": zero_v} if s.moving else wall_v
    fields = {
        "U": _field(
            "volVectorField",
            [0, 1, -1, 0, 0, 0, 0],
            zero_v,
            s,
            body_u,
            wall_v,
            {"type": "pressureInletOutletVelocity", "value": zero_v},
        ),
        "p": _field(
            "volScalarField",
            [0, 2, -2, 0, 0, 0, 0],
            0.0,
            s,
            {"type": "zeroGradient"},
            {"type": "zeroGradient"},
            {"type": "totalPressure", "p0": 0.0, "value": 0.0},
        ),
        "nut": _field(
            "volScalarField",
            [0, 2, -1, 0, 0, 0, 0],
            0.0,
            s,
            {"type": "nutkWallFunction", "value": 0.0},
            {"type": "nutkWallFunction", "value": 0.0},
            {"type": "calculated", "value": 0.0},
        ),
        "k": _field(
            "volScalarField",
            [0, 2, -2, 0, 0, 0, 0],
            K0,
            s,
            {"type": "kqRWallFunction", "value": K0},
            {"type": "kqRWallFunction", "value": K0},
            {"type": "inletOutlet", "inletValue": K0, "value": K0},
        ),
        "omega": _field(
            "volScalarField",
            [0, 0, -1, 0, 0, 0, 0],
            OMEGA0,
            s,
            {"type": "omegaWallFunction", "value": OMEGA0},
            {"type": "omegaWallFunction", "value": OMEGA0},
            {"type": "inletOutlet", "inletValue": OMEGA0, "value": OMEGA0},
        ),
    }
    if s.turbulence is Turbulence.LAMINAR:
        for name in ("nut", "k", "omega"):
            fields.pop(name)
    if s.turbulence in LES_MODELS:
        fields.pop("omega")
        fields["nut"] = _field(
            "volScalarField",
            [0, 2, -1, 0, 0, 0, 0],
            0.0,
            s,
            {"type": "zeroGradient"},
            {"type": "zeroGradient"},
            {"type": "calculated", "value": 0.0},
        )
    if s.inflow_m_s > 0:
        flume_fields(fields, s)
    if s.moving:
        fields[MOTION_FIELD] = point_motion(s)
    return fields


INFLOW_TURBULENCE_INTENSITY = 0.01  # a quiet flume
INFLOW_VISCOSITY_RATIO = 1.0  # nut / nu of the inflow: free-stream turbulence, no more


def flume_fields(fields: dict[str, dict], s: FlowSettings) -> None:
    """Turn the tank's fields into a flume's: uniform U along +x from the inlet, p = 0 at the
    outlet, the walls and the top slip (no boundary layers of their own to feed the fish's
    forces). Inflow k from 1 % intensity, omega = k / nut with nut = nu."""
    u = [s.inflow_m_s, 0.0, 0.0]
    k = 1.5 * (INFLOW_TURBULENCE_INTENSITY * s.inflow_m_s) ** 2
    omega = k / (INFLOW_VISCOSITY_RATIO * s.nu_m2_s)
    inlet: dict[str, dict] = {
        "U": {"type": "fixedValue", "value": u},
        "p": {"type": "zeroGradient"},
        "k": {"type": "fixedValue", "value": k},
        "omega": {"type": "fixedValue", "value": omega},
    }
    outlet: dict[str, dict] = {
        "U": {"type": "inletOutlet", "inletValue": [0.0, 0.0, 0.0], "value": u},
        "p": {"type": "fixedValue", "value": 0.0},
        "k": {"type": "inletOutlet", "inletValue": k, "value": k},
        "omega": {"type": "inletOutlet", "inletValue": omega, "value": omega},
    }
    start: dict[str, object] = {"U": u, "k": k, "omega": omega}
    for name, field in fields.items():
        boundary = field["boundaryField"]
        still = {"type": "slip"} if name == "U" else {"type": "zeroGradient"}
        for patch in (*s.wall_patches, *s.open_patches):
            boundary[patch] = dict(still)
        calculated: dict = {"type": "calculated", "value": 0.0}
        for patch in s.inlet_patches:
            boundary[patch] = dict(inlet.get(name, calculated))
        for patch in s.outlet_patches:
            boundary[patch] = dict(outlet.get(name, calculated))
        if name in start:
            field["internalField"] = start[name]


def _field(cls, dims, value, s: FlowSettings, body: dict, wall: dict, opening: dict) -> dict:
    boundary = {name: dict(body) for name in s.body_patches}
    boundary.update({name: dict(wall) for name in s.wall_patches})
    boundary.update({name: dict(opening) for name in s.open_patches})
    return {
        "FoamFile": {"class": cls},
        "dimensions": dims,
        "internalField": value,
        "boundaryField": boundary,
    }


# The body's velocity comes from constant/boundaryData/<patch>/<time>/pointMotionU (see
# foamrun.py): read on demand, mapped by nearest reference point, so the same files feed serial
# and parallel runs.
MOTION_FIELD = "pointMotionU"
BODY_MOTION_BC = {
    "type": "timeVaryingMappedFixedValue",
    "mapMethod": "nearest",
    "value": [0.0, 0.0, 0.0],
}


def point_motion(s: FlowSettings) -> dict:
    fixed = {"type": "fixedValue", "value": [0.0, 0.0, 0.0]}
    still = (*s.wall_patches, *s.open_patches, *s.inlet_patches, *s.outlet_patches)
    boundary = {name: dict(fixed) for name in still}
    boundary.update({name: dict(BODY_MOTION_BC) for name in s.body_patches})
    return {
        "FoamFile": {"class": "pointVectorField"},
        "dimensions": [0, 1, -1, 0, 0, 0, 0],
        "internalField": [0.0, 0.0, 0.0],
        "boundaryField": boundary,
    }
