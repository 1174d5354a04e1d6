"""Column layout of the model's arrays (Taichi ndarrays, shared by kernels and host code).

``bodies`` (N, NB, real): one row per iceberg, columns grouped by phase (below).
``ints`` (N, NI, i32): per-body integers.
``cdata`` (slots, N, NC, real) and ``cpartner`` (slots, N, i32): contacts of body i with
partners j > i, sorted by j, at ``[0, i]``, ``[1, i]``, ... (slot-major: most bodies use one
or two slots, so a sweep over the bodies reads them as dense streams). CGAP is the gap when
the contact was found; the correction pass replaces it by the predicted end-of-step gap
(nothing reads it after that step).
``nlist`` (N, 2 ENTRIES + ENTRIES PAIRS, i32) and ``nlpose`` (N, ENTRIES, 5, real): body
i's candidate lists, one entry e per partner j > i. ``nlist[i]`` holds the partners
(``[e]``, -1: free), the counts (``[ENTRIES + e]``, -1: none kept) and then each entry's
codes (``[2 ENTRIES + e PAIRS + q]``): one 1 kB row per body, the partners and counts in
its first cache line. ``nlpose`` is the pose each list was made at
``(tu, tv, c, s, touch + skin)``; NEXT_ENTRY in ``ints`` is the entry a new partner takes
(round robin). See ``step.narrow``.
``cells`` (ncells + 1, 3, i32): counting-sort cell list.
``par`` (NP, real): run-time parameters.
``acc`` (NA, f64): cumulative scalar accumulators.
``ipar`` (NQ, i64): run-time integer parameters and counters.
"""

# bodies: 24 columns, 192 bytes = three 64-byte cache lines per row in f64, grouped by the
# phases that read them together (at large N the sweeps are bound by memory traffic):
# line 0: what the impulse pass and the correction sweeps touch (INV_MASS = 1 / MASS, rounded
# once in the model's precision: the same bits as dividing on the device)
X, Z, VX, VZ, OM, INV_MASS, SHIFT_X, SHIFT_Z = 0, 1, 2, 3, 4, 5, 6, 7
# line 1: what detection reads besides x and z
COS, SIN, WIDTH, THICK, RADIUS, BOUND, REACH, MOTION = 8, 9, 10, 11, 12, 13, 14, 15
# line 2: the tilt, the rest of the constants and the per-body accumulators
TH, MASS, INERTIA, DRAG_WORK, WALL_PZ, WALL_GAP, KINETIC, POTENTIAL = 16, 17, 18, 19, 20, 21, 22, 23
NB = 24
STATE_COLS = {"x": X, "z": Z, "theta": TH, "vx": VX, "vz": VZ, "omega": OM}
CONST_COLS = {"width": WIDTH, "thickness": THICK, "mass": MASS, "inertia": INERTIA, "radius": RADIUS, "bound": BOUND}

# ints
CELL, NCONTACT, WALL_ON, SORTED, PUSHED, NEXT_ENTRY = 0, 1, 2, 3, 4, 5
NI = 6

# cdata
CPX, CPZ, CNX, CNZ, CGAP = 0, 1, 2, 3, 4
NC = 5

# cells
COUNT, START, FILL = 0, 1, 2

# par (real)
DT, RESTITUTION, DRAG_LIN, DRAG_ANG, WATER, WALL_X, BOUND_MAX, REACH_MAX, SPEED_MAX, EPS = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
NP = 10  # EPS: the machine epsilon of the model's precision

# acc (f64)
ACC_COLLISION, ACC_CORRECTION, ACC_WALL_IMPULSE, ACC_IMPULSE = 0, 1, 2, 3
NA = 4

# ipar (i64)
N, K, SLOTS, PASSES, NCELLS, DISCS, CONTACTS, OVERFLOW, AGAIN, LISTS = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
NQ = 10

# Bounds on the iterations inside one step (see physics.step).
MAX_DETECT = 16  # impulse passes again while a contact would still close by > DEEP_FRACTION r,
#                  detecting again first if an impulse made some body outrun its reach
DEEP_FRACTION = 0.1
MAX_CORRECT = 4  # correction sweeps while some overlap is still being pushed apart
# Candidate lists (step.narrow): partners kept per body, disc pairs kept per partner, and
# the skin (a fraction of the smaller disc radius) added to the touching distance.
ENTRIES = 4
PAIRS = 62
SKIN = 0.2
