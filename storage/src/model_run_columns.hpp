#pragma once
// Column names of the depth calibration a model run stores (table model_runs, view predictions)
// and of an inspection's deepest point (table inspections), as string-literal macros: the
// migrations' SQL is literal text, and the writer, the staff queries and the typed readers spell
// the same names from here.

// ρ, the true combined mean depth over the model's (schema 16).
#define GW_COL_DEPTH_ESTIMATE "wear_mean_estimate_m"
#define GW_COL_DEPTH_RATIO "wear_depth_ratio"
#define GW_COL_DEPTH_RATIO_LOG_SD "wear_depth_ratio_log_sd"
#define GW_COL_DEPTH_INSPECTIONS "wear_depth_inspections"
#define GW_DEPTH_RATIO_COLUMNS GW_COL_DEPTH_ESTIMATE ", " GW_COL_DEPTH_RATIO ", " GW_COL_DEPTH_RATIO_LOG_SD ", " GW_COL_DEPTH_INSPECTIONS

// P, the deepest point over the mean from inspected profiles (schema 18): the posterior mean and
// SD of ln P, the resulting deepest / mean (exp of the mean: the posterior median) and how many
// inspected deepest points it rests on.
#define GW_COL_PEAK_LOG_MEAN "wear_peak_ratio_log_mean"
#define GW_COL_PEAK_LOG_SD "wear_peak_ratio_log_sd"
#define GW_COL_PEAK_RATIO "wear_peak_ratio"
#define GW_COL_PEAK_INSPECTIONS "wear_peak_inspections"
#define GW_PEAK_RATIO_COLUMNS GW_COL_PEAK_LOG_MEAN ", " GW_COL_PEAK_LOG_SD ", " GW_COL_PEAK_RATIO ", " GW_COL_PEAK_INSPECTIONS

// An inspection's deepest flank point and its depths' own relative SD (schema 17).
#define GW_COL_INSPECTION_DEPTH_MAX "wear_depth_max_m"
#define GW_COL_INSPECTION_DEPTH_SD "wear_depth_relative_sd"
#define GW_INSPECTION_DEEPEST_COLUMNS GW_COL_INSPECTION_DEPTH_MAX ", " GW_COL_INSPECTION_DEPTH_SD
