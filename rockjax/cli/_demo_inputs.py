"""The inputs of ``rockjax demo``, the examples of the paper (Galvez et al., Sect. 2), and the
files it writes; the parapet and the release are the defaults of ``rockjax ida`` and
``rockjax calibrate`` too."""

PARAPET_B, PARAPET_H = 0.25, 3.0  # [m], the paper's reference parapet
FACADE_B, FACADE_H = 0.2, 1.5  # [m]
FACADE_GAP = 0.001  # facade-to-return-wall gap [m]
RELEASE = 0.5  # release rotation theta0 / eta [-] of every free-rocking run
RICKER_PGA, RICKER_PERIOD = 4.0, 0.5  # [m/s^2], [s]: rocks the parapet hard, without overturning
N_BOUNCES = 3  # bounces evaluated with Eq. (6), as the paper does
BETA_MAX_RATIO = 1.5  # the sweep spans 0 .. 1.5 beta_DeJong
N_BETA, N_BETA_QUICK = 7, 4  # 0, 0.25, ..., 1.5 beta_DeJong; 0, 0.5, 1, 1.5 beta_DeJong

# Every parapet run (free, pulse, sweep) shares the output step, the duration and the DEM step,
# so each model compiles once for all of them: compilation, not stepping, is what costs time.
DT_OUT = 0.005  # output step [s] of the parapet runs (and the Ricker record's step)
PARAPET_DURATION = 8.0  # [s], at least: 3 bounces at e = 1 (free-rocking period 2.4 s)
FACADE_DT_OUT = 0.002  # [s]: facade bounces are short
FACADE_DURATION = 1.5  # [s]: the facade is at rest after about 1 s
DEMO_FILES = (
    "parapet_free_rocking.png",
    "parapet_peaks.png",
    "facade_free_rocking.png",
    "parapet_ricker.png",
    "parapet_free_rocking.csv",
    "facade_free_rocking.csv",
    "parapet_ricker.csv",
    "e_beta.png",
    "e_beta.csv",
    "calibration.png",
    "ida_pulses_housner.nc",
    "ida_pulses_housner.png",
    "ida_pulses_dem.nc",
    "ida_pulses_dem.png",
    "results.json",
)  # what `rockjax demo` writes into --out, each checked before the first run
