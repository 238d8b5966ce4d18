"""Rule fig_wheelslip: paper Figs 4-8, the PID schedule, calibration and closed loop."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr

from uqdrive.plots import wheelslip as pw
from uqdrive.plots.figure import save_figure
from uqdrive.wheelslip.quarter_car import QuarterCar
from uqdrive.settings import Settings

i, o, config = snakemake.input, snakemake.output, snakemake.params.config  # noqa: F821
car = QuarterCar.from_settings(Settings.from_config(config).wheelslip)
gps = [xr.load_dataset(p) for p in i.gp]
save_figure(pw.friction_curves(car, config["wheelslip"]["curves_mu_H"]), o.curves)
save_figure(pw.gp_function(gps[0]), o.function)
save_figure(pw.gp_slope(gps[0]), o.slope)
for ds, path in zip(gps, o.poles):
    save_figure(pw.pole_locations(ds), path)
slopes = {"paper E(Gamma) = %.4f" % config["wheelslip"]["paper_slope"]["mean"]: config["wheelslip"]["paper_slope"]["mean"]}
slopes.update({f"uqdrive GP, {ds.attrs['n_train']} points (E = {ds.attrs['E_Gamma']:.3f})": ds.attrs["E_Gamma"] for ds in gps})
slopes["true slope %.4f" % gps[0].attrs["true_Gamma"]] = gps[0].attrs["true_Gamma"]
save_figure(pw.pid_schedule_figure(car, slopes, config["wheelslip"]["speed_range"]), o.schedule)
save_figure(pw.calibration_figure([xr.load_dataset(p) for p in i.calibration]), o.calibration)
save_figure(pw.closed_loop_figure(xr.load_dataset(i.closed_loop)), o.closed_loop)
