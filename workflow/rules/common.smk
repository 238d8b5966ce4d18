# Shared names and helpers of the rules: output folders, target lists, input selectors.

FIG = f"{OUT}/figures"
N_LEVELS = len(NOISE_LEVELS)
APPENDIX_A = list(range(1, 2 * N_LEVELS + 1)) if {"lst", "nlst"} <= set(MODELS) else []
FIGURES = [f"{FIG}/fig_2_3.png", f"{FIG}/fig_5_2.png", f"{FIG}/fig_7_1.png"]
FIGURES += [f"{FIG}/fig_5_3.png", f"{FIG}/fig_5_4.png", f"{FIG}/fig_pce_convergence.png"] if "normal" in STEERS and "lst" in MODELS else []
if "normal" in STEERS:
    FIGURES += [f"{FIG}/fig_6_{i}.png" for i in (1, 2, 3, 4, 5, 6)] if APPENDIX_A else []
    FIGURES += [f"{FIG}/fig_A{n}.png" for n in APPENDIX_A]


def appendix_a_model(n):
    """Thesis numbering: A.1-A.L are the LST data sets, A.L+1-A.2L the NLST ones."""
    return "lst" if int(n) <= N_LEVELS else "nlst"

WS_FIGURES = ["paper_fig_4", "paper_fig_5", "paper_fig_6", "paper_pid_schedule", "paper_calibration", "paper_closed_loop"]
FIGURES += [f"{FIG}/{name}.png" for name in WS_FIGURES]
FIGURES += [f"{FIG}/paper_fig_poles_{n}.png" for n in config["wheelslip"]["gp"]["training_sizes"]]

ID_FIGURE_NAMES = [f"fig_6_{i}" for i in range(7, 16)] + ["fig_robust_start"] + [f"fig_B{i}" for i in range(1, 14)]
FIGURES += [f"{FIG}/{name}.png" for name in ID_FIGURE_NAMES] if {"lst", "nlst"} <= set(MODELS) and set(STEERS) == {"normal", "inverted"} else []
FIGURES += [f"{FIG}/{name}.png" for name in ("fig_6_16", "fig_6_17", "fig_6_18", "fig_gamma_sweep")] if ID_FIGURE_NAMES and {"lst", "nlst"} <= set(MODELS) else []
FIGURES += [f"{FIG}/posterior_{kind}_{case}.png" for kind in ("corner", "trace") for case in ("lst", "nlst", "lst_noise")] if {"lst", "nlst"} <= set(MODELS) else []
