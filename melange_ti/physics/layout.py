"""Column layout of the model's arrays (Taichi ndarrays, shared by kernels and host code).

``bodies`` (N, NB, real): one row per iceberg, hot state first.
``ints`` (N, NI, i32): per-body integers.
``cdata`` (N, slots, NC, real) and ``cpartner`` (N, slots, i32): contacts of body i with
partners j > i, sorted by j. CGAP is the gap when the contact was found; the correction
pass replaces it by the predicted end-of-step gap (nothing reads it after that step).
``cells`` (ncells + 1, 3, i32): counting-sort cell list.
``par`` (NP, real): run-time parameters.
``acc`` (NA, f64): cumulative scalar accumulators.
``ipar`` (NQ, i64): run-time integer parameters and counters.
"""

# bodies: state
X, Z, TH, VX, VZ, OM = 0, 1, 2, 3, 4, 5
# bodies: constants
WIDTH, THICK, MASS, INERTIA, RADIUS, BOUND = 6, 7, 8, 9, 10, 11
# bodies: per-step scratch and per-body accumulators
REACH, COS, SIN, DRAG_WORK, SHIFT_X, SHIFT_Z, WALL_PZ, WALL_GAP, KINETIC, POTENTIAL, MOTION = (
    12,
    13,
    14,
    15,
    16,
    17,
    18,
    19,
    20,
    21,
    22,
)
NB = 23
STATE_COLS = {"x": X, "z": Z, "theta": TH, "vx": VX, "vz": VZ, "omega": OM}
CONST_COLS = {"width": WIDTH, "thickness": THICK, "mass": MASS, "inertia": INERTIA, "radius": RADIUS, "bound": BOUND}

# ints
CELL, NCONTACT, WALL_ON, SORTED, PUSHED = 0, 1, 2, 3, 4
NI = 5

# cdata
CPX, CPZ, CNX, CNZ, CGAP = 0, 1, 2, 3, 4
NC = 5

# cells
COUNT, START, FILL = 0, 1, 2

# par (real)
DT, RESTITUTION, DRAG_LIN, DRAG_ANG, WATER, WALL_X, BOUND_MAX, REACH_MAX, SPEED_MAX = 0, 1, 2, 3, 4, 5, 6, 7, 8
NP = 9

# acc (f64)
ACC_COLLISION, ACC_CORRECTION, ACC_WALL_IMPULSE, ACC_IMPULSE = 0, 1, 2, 3
NA = 4

# ipar (i64)
N, K, SLOTS, PASSES, NCELLS, DISCS, CONTACTS, OVERFLOW, AGAIN = 0, 1, 2, 3, 4, 5, 6, 7, 8
NQ = 9

# Bounds on the iterations inside one step (see physics.step).
MAX_DETECT = 16  # impulse passes again while a contact would still close by > DEEP_FRACTION r,
#                  detecting again first if an impulse made some body outrun its reach
DEEP_FRACTION = 0.1
MAX_CORRECT = 4  # correction sweeps while some overlap is still being pushed apart
