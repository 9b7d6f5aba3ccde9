"""Index layout of the geartrain model, shared by the packer (Python) and the
compiled model (numba).

The compiled model sees numbers, not objects: a plant and its controller are
packed once into one float64 parameter vector ``p`` whose slots are named
here; the effects' blocks follow ``P_SIZE`` (laid out from their declarations
by ``plant/effects/codegen.py``).  Every quantity in ``p`` is SI (angles in
rad, gains in V/rad, ...).  Numba reads these module-level integers as
compile-time constants.
"""

# ---- parameter vector p ---------------------------------------------------
P_R = 0            # motor resistance, ohm
P_L = 1            # motor inductance, H
P_KT = 2           # torque constant, N m / A
P_KE = 3           # back-emf constant, V s / rad
P_JM = 4           # rotor inertia (+ pinion when there is no shaft), kg m^2
P_BM = 5           # motor viscous damping, N m s / rad
P_VMAX = 6         # voltage limit, V
P_N = 7            # gear ratio, motor turns per output turn
P_H = 8            # half the total clearance at the output gear, rad
P_KMESH = 9        # mesh stiffness at the output gear, N m / rad
P_DMESH = 10       # mesh damping at the output gear, N m s / rad
P_LAW = 11         # contact law: LAW_DUBOWSKY or LAW_ELASTO
P_JL = 12          # load inertia seen by the output gear (incl. reflected carriage), kg m^2
P_BL = 13          # load viscous damping (incl. reflected carriage), N m s / rad
P_HAS_SHAFT = 14   # 1.0 when a torsional shaft separates rotor and pinion
P_KS = 15          # shaft stiffness, N m / rad
P_DS = 16          # shaft damping, N m s / rad
P_JP = 17          # pinion inertia, kg m^2 (only with a shaft)
P_CTRL = 18        # controller kind: CTRL_*
P_KP = 19          # proportional gain, V / rad
P_KI = 20          # integral gain of Kp*(e + Ki*int e), 1/s
P_KD = 21          # derivative gain of Kp*(... + Kd*de/dt), s
P_TF = 22          # derivative filter time constant, s
P_BAND = 23        # bang-bang half band, rad (no output while |e| <= band/2)
P_SHIFT = 24       # set-point shift, rad (0 = off)
P_TORQUE_IN = 25   # 1.0: the input drives the motor shaft as a torque (no electrics)
P_COMP = 26        # backlash compensator keying the set-point shift: COMP_* (P_SHIFT > 0 only)
P_SPEED_EPS = 27   # speed threshold of the thesis shift's sign test, rad/s (simulate.SHIFT_SPEED_REL)
P_RIGID = 28       # 1.0: rigid gear (no mesh, no clearance): rotor, pinion and load turn as one
P_DRIVE_GAIN = 29  # torque input mode: rotor torque per unit of input (1 for N m; lead/(2 pi N) for N)
P_KV = 30          # sampled position-velocity controller: velocity gain, V / (rad/s) at the output
P_CTRL_GAIN = 31   # sampled controller: input units per controller volt (EMPS gtau, N/V)
P_FRIC_EPS_M = 32  # friction regularisation speed at the motor, rad/s (the solver's)
P_FRIC_EPS_L = 33  # friction regularisation speed at the load, rad/s
P_STICK_M = 34     # 1.0 when event-driven stick-slip friction acts at the motor (packer)
P_STICK_L = 35     # 1.0 when it acts at the load (packer)
P_STOP_EPS_M = 36  # a slipping body on the rotor's side has stopped when its speed is this far past 0,
P_STOP_EPS_L = 37  # ... on the load's: the speeds' absolute tolerances, rad/s (the solver's)
P_DELAY = 52       # sampled controller: 1.0 holds the previous sample's command (one sample of delay)
P_FF = 53          # velocity feedforward, V per rad/s of set-point speed at the output (0 = none)
P_REF_SLOPE = 54   # the current segment's set-point slope, rad/s (written by model.start_segment)
P_KRATE = 55       # rate damping of damped_feedforward, V per rad/s of the error rate dr/dt - w_m/N (0 = none)
P_PWL = 56         # 1.0 when every effect keeps the right-hand side piecewise-linear (packer)
P_CURVED_M = 57    # 1.0 when the right-hand side would be piecewise-linear but for the sliding level of the
P_CURVED_L = 58    # stick-slip law at the motor (the load), which curves with its speed: Stribeck's (packer)
P_SIZE = 64        # the plant's and controller's slots; the effects' blocks follow
                   # (plant/effects/codegen.py lays them out from their declarations)

LAW_DUBOWSKY = 0.0
LAW_ELASTO = 1.0
LAW_LINEAR = 2.0   # unclipped spring-damper: contact lasts until the penetration is 0 (may pull)

COMP_THESIS = 0.0     # thesis Equation 1: shift sign = sign of the motor speed (flips on overshoot)
COMP_DIRECTION = 1.0  # shift sign = direction the set point last moved (ramp slope or step),
                      # held through dwells; changes only at the profile's corners

CTRL_OPEN = 0.0      # the segment table is the motor voltage (or drive torque), zero-order hold
CTRL_BANGBANG = 1.0
CTRL_P = 2.0
CTRL_PI = 3.0
CTRL_PID = 4.0
CTRL_SAMPLED_PV = 5.0  # sampled position-velocity cascade (EMPS): updated at the segment corners

# ---- state vector x -------------------------------------------------------
X_I = 0        # motor current, A
X_THM = 1      # rotor angle, rad
X_WM = 2       # rotor speed, rad/s
X_PHI = 3      # shaft twist rotor - pinion, rad (0 without a shaft)
X_WP = 4       # pinion speed, rad/s (unused without a shaft)
X_DELTA = 5    # mesh relative angle at the output, theta_pinion/N - theta_load, rad
X_WL = 6       # load speed, rad/s
X_ZI = 7       # controller integral of the motor-side error, rad s
X_ZD = 8       # derivative filter state, rad
N_DYN = 9      # states with dynamics (Jacobian, implicit solve)
X_IAE = 9      # integral of |output error|, rad s
X_ISE = 10     # integral of output error squared, rad^2 s
N_STATE = 11

# ---- discrete modes -------------------------------------------------------
M_CONTACT = 0  # -1, 0 (free flight), +1
M_BB = 1       # bang-bang output sign -1, 0, +1
M_SHIFT = 2    # sign used by the set-point shift: thesis: +1 when motor speed >= 0, else -1;
               # COMP_DIRECTION: the set point's last direction (0 before it first moves)
M_SAT = 3      # side of the amplifier's limit a continuous law is on: -1, 0 (inside), +1
M_DAMP = 4     # ElastoBacklash in contact: 1 while the damping torque is limited to the
               # spring torque (T = 2 Tc), 0 while it is not (T = Tc + Td)
M_STICK_M = 5  # stick-slip friction on the rotor's body: +1 / -1 slipping forward / backward, 0 stuck
M_STICK_L = 6  # ... on the body carrying the load (plant/friction.py says which body each is)
N_MODES = 7

# ---- guards (an event fires when a guard goes from < 0 to >= 0, or from ----
#      exactly 0 where a step starts to > 0) -------------------------------
G_ENTER_POS = 0
G_ENTER_NEG = 1
G_LEAVE = 2
G_BB_A = 3
G_BB_B = 4
G_SHIFT = 5
G_SAT = 6      # a continuous law reaches or leaves the amplifier's limit (V)
G_KINK = 7     # ElastoBacklash's damping meets its spring torque (N m)
G_STICK_M = 8  # stick-slip on the rotor's body: slipping, its speed reaches 0 (rad/s); stuck, the
               # torque on it reaches its breakaway level (N m)
G_STICK_L = 9  # the same on the body carrying the load
N_GUARDS = 10

# ---- sampled output columns ----------------------------------------------
O_SETPOINT = 0     # rad
O_LOAD = 1         # load angle, rad
O_MOTOR = 2        # rotor angle, rad
O_VOLTAGE = 3      # applied voltage (or drive torque), V
O_CURRENT = 4      # A
O_WM = 5           # rad/s
O_WL = 6           # rad/s
O_TORQUE = 7       # mesh contact torque on the load, N m
O_DELTA = 8        # mesh relative angle, rad
N_OUT = 9

# ---- run statistics: the solver's (solver.integrate.S_*), then the model's
from .solver.integrate import (N_SOLVER_STATS, S_EVENTS, S_FEVALS, S_REJECTED, S_STATUS,  # noqa: E402,F401
                               S_STEPS, S_T_FAIL, STATUS_CHATTER, STATUS_MAX_STEPS, STATUS_NONFINITE,
                               STATUS_OK, STATUS_STEP_TOO_SMALL, METHOD_DOPRI, METHOD_RODAS4, METHOD_RODAS4_EXP,
                               METHOD_ROSENBROCK)

S_IAE = N_SOLVER_STATS + 0      # rad s
S_ISE = N_SOLVER_STATS + 1      # rad^2 s
S_MAX_ERR = N_SOLVER_STATS + 2  # rad
S_T_SAT = N_SOLVER_STATS + 3    # s spent with the controller output at the voltage limit
S_IMPACTS = N_SOLVER_STATS + 4  # contact onsets
S_SWITCHES = N_SOLVER_STATS + 5 # changes of sign of the applied voltage (continuous laws: past rtol * Vmax)
N_MODEL_STATS = 6
N_STATS = N_SOLVER_STATS + N_MODEL_STATS

STATUS_TEXT = {
    STATUS_OK: "ok",
    STATUS_STEP_TOO_SMALL: "step size fell below the round-off limit",
    STATUS_MAX_STEPS: "step budget exhausted",
    STATUS_NONFINITE: "state became non-finite",
    STATUS_CHATTER: "modes switched back and forth without time advancing",
}
