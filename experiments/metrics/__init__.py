"""The paper's validation metrics (Sec. 2.5.3-2.5.6, Appendix D), one pure function each.

Stage 1 and 2 (square, figure-eight), per run:

    closure error          e_c = ||p_K - p_1||                            (Sec. 2.5.2)
    cross-track RMSE/max   nearest-point distance of p_k to the nominal path polyline
    heading RMSE           sqrt(mean wrap(theta_est,k - theta_ref,k)^2)
    loop diameters         2 R of an algebraic (Kasa) circle fit to each figure-eight loop
    optimism gap           e_c,GT - e_c,EKF                               (Sec. 4.2)

Estimator consistency, per EKF output k against ground truth (not in the paper):

    NEES                   eps_k = e_k^T P_k^-1 e_k,  e = pose error [x, y, yaw]
    95 % band              [chi2_n^-1(0.025), chi2_n^-1(0.975)], n = 3 (0.216, 9.348)
    band of an N-run mean  [chi2_Nn^-1(0.025), chi2_Nn^-1(0.975)] / N
    end-position 2-sigma   2 sqrt(lambda_max(P_xy)), the 2-sigma ellipse's semi-major axis

Cross-domain deviation over K synchronised samples, both runs anchored at (0, 0, 0) (Eq. 12)
from time zero, the first command with v > 0.01 m/s (Sec. 2.5.3):

    D_trans = sqrt(1/K sum_k ||p_sim,k - p_real,k||^2)                   (Eq. 13)
    D_rot   = sqrt(1/K sum_k wrap(theta_sim,k - theta_real,k)^2)         (Eq. 14)
    SSIM(M_sim, M_real) of 8-bit occupancy maps                         (Eq. 15 / A19)

Stage 3 (maze with the dynamic cylinder):

    S_vector = [P_success, C_count, d_min, E_recovery, t_nav]           (Eq. 16)
    D_traj,i = sqrt(sum_k w_ik d^2(p_ik, P_0) / sum_k w_ik)             (Eq. 19)
    d(p, P_0) = min_{q in P_0} ||p - q||                                (Eq. 20)
    d_min = min_{t >= t_ins} d_geom(B_robot(t), C_cyl)                  (Eq. 21)

and the paper's summaries: mean +- SD with a 95 % CI (Stages 1-2; t-based as the paper's, or
one that stays in the quantity's domain: log-normal, bootstrap, binomial), median [IQR]
(continuous Stage 3 outcomes). Angles are in radians, lengths in metres, times in seconds.
"""

from __future__ import annotations

from jackson.experiments.metrics.alignment import (
    TIME_ZERO_V_M_S as TIME_ZERO_V_M_S,
)
from jackson.experiments.metrics.alignment import (
    align_start as align_start,
)
from jackson.experiments.metrics.alignment import (
    d_rot as d_rot,
)
from jackson.experiments.metrics.alignment import (
    d_trans as d_trans,
)
from jackson.experiments.metrics.alignment import (
    synchronise as synchronise,
)
from jackson.experiments.metrics.alignment import (
    time_zero_index as time_zero_index,
)
from jackson.experiments.metrics.inputs import (
    FloatArray as FloatArray,
)
from jackson.experiments.metrics.inputs import (
    MetricInputError as MetricInputError,
)
from jackson.experiments.metrics.inputs import (
    NoMotionError as NoMotionError,
)
from jackson.experiments.metrics.inputs import (
    wrap_angle as wrap_angle,
)
from jackson.experiments.metrics.maps import (
    SSIM_DATA_RANGE as SSIM_DATA_RANGE,
)
from jackson.experiments.metrics.maps import (
    SSIM_K1 as SSIM_K1,
)
from jackson.experiments.metrics.maps import (
    SSIM_K2 as SSIM_K2,
)
from jackson.experiments.metrics.maps import (
    SSIM_WIN_SIZE as SSIM_WIN_SIZE,
)
from jackson.experiments.metrics.maps import (
    map_ssim as map_ssim,
)
from jackson.experiments.metrics.maps import (
    occupancy_ssim as occupancy_ssim,
)
from jackson.experiments.metrics.nees import (
    NEES_CONFIDENCE as NEES_CONFIDENCE,
)
from jackson.experiments.metrics.nees import (
    SINGULAR_RCOND as SINGULAR_RCOND,
)
from jackson.experiments.metrics.nees import (
    nees as nees,
)
from jackson.experiments.metrics.nees import (
    nees_band as nees_band,
)
from jackson.experiments.metrics.nees import (
    position_two_sigma as position_two_sigma,
)
from jackson.experiments.metrics.paths import (
    closure_error as closure_error,
)
from jackson.experiments.metrics.paths import (
    cross_track_rmse as cross_track_rmse,
)
from jackson.experiments.metrics.paths import (
    figure_eight_path as figure_eight_path,
)
from jackson.experiments.metrics.paths import (
    figure_eight_split as figure_eight_split,
)
from jackson.experiments.metrics.paths import (
    final_heading_error as final_heading_error,
)
from jackson.experiments.metrics.paths import (
    fit_circle_kasa as fit_circle_kasa,
)
from jackson.experiments.metrics.paths import (
    heading_rmse as heading_rmse,
)
from jackson.experiments.metrics.paths import (
    loop_diameters as loop_diameters,
)
from jackson.experiments.metrics.paths import (
    max_cross_track as max_cross_track,
)
from jackson.experiments.metrics.paths import (
    optimism_gap as optimism_gap,
)
from jackson.experiments.metrics.paths import (
    point_to_polyline_distance as point_to_polyline_distance,
)
from jackson.experiments.metrics.paths import (
    square_path as square_path,
)
from jackson.experiments.metrics.safety import (
    CYLINDER_RADIUS_M as CYLINDER_RADIUS_M,
)
from jackson.experiments.metrics.safety import (
    ENVELOPE_X_M as ENVELOPE_X_M,
)
from jackson.experiments.metrics.safety import (
    ENVELOPE_Y_M as ENVELOPE_Y_M,
)
from jackson.experiments.metrics.safety import (
    STAGE3_CYLINDER as STAGE3_CYLINDER,
)
from jackson.experiments.metrics.safety import (
    Cylinder as Cylinder,
)
from jackson.experiments.metrics.safety import (
    SafetyVector as SafetyVector,
)
from jackson.experiments.metrics.safety import (
    d_min as d_min,
)
from jackson.experiments.metrics.safety import (
    envelope_to_circle_distance as envelope_to_circle_distance,
)
from jackson.experiments.metrics.safety import (
    safety_vector as safety_vector,
)
from jackson.experiments.metrics.summaries import (
    BOOTSTRAP_RESAMPLES as BOOTSTRAP_RESAMPLES,
)
from jackson.experiments.metrics.summaries import (
    BOOTSTRAP_SEED as BOOTSTRAP_SEED,
)
from jackson.experiments.metrics.summaries import (
    CI_METHODS as CI_METHODS,
)
from jackson.experiments.metrics.summaries import (
    Domain as Domain,
)
from jackson.experiments.metrics.summaries import (
    MeanSdCi as MeanSdCi,
)
from jackson.experiments.metrics.summaries import (
    MedianIqr as MedianIqr,
)
from jackson.experiments.metrics.summaries import (
    bootstrap_mean_ci as bootstrap_mean_ci,
)
from jackson.experiments.metrics.summaries import (
    format_mean_sd as format_mean_sd,
)
from jackson.experiments.metrics.summaries import (
    mean_sd_ci as mean_sd_ci,
)
from jackson.experiments.metrics.summaries import (
    median_iqr as median_iqr,
)
from jackson.experiments.metrics.trajectory import (
    BASELINE_SAMPLES as BASELINE_SAMPLES,
)
from jackson.experiments.metrics.trajectory import (
    arc_length_weights as arc_length_weights,
)
from jackson.experiments.metrics.trajectory import (
    d_traj as d_traj,
)
from jackson.experiments.metrics.trajectory import (
    d_traj_leave_one_out as d_traj_leave_one_out,
)
from jackson.experiments.metrics.trajectory import (
    median_baseline as median_baseline,
)
from jackson.experiments.metrics.trajectory import (
    resample_by_arc_length as resample_by_arc_length,
)
