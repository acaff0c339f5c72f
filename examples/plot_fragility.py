"""
Fragility curve of a drift limit under stochastic ground motion
===============================================================

``scenarios/ground_motion.toml`` (a 1 Hz primary with a vibro-impact NES under Clough-Penzien
ground motion on medium soil, with a limit on the storey drift), shortened to 40 realisations of
20 s at each of six intensities (a multiple-stripe analysis). Each stripe's exceeded fraction comes
with its 95 % Wilson interval; the lognormal fragility curve ``P = Phi(ln(IM / median) / beta)`` is
fitted by binomial maximum likelihood over the stripes, with bootstrap bounds on ``median`` and
``beta`` (as ``vines-stoch fragility`` does).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import tomlkit
from scipy.stats import norm

import vines_stoch
from vines_stoch.fragility import fragility

# The shipped scenarios: run from the repository or from examples/ (as the gallery does).
SCENARIOS = next(p / "scenarios" for p in (Path.cwd(), Path.cwd().parent) if (p / "scenarios").is_dir())
doc = tomlkit.parse((SCENARIOS / "ground_motion.toml").read_text())
doc["simulation"]["duration"] = 20.0
del doc["simulation"]["history"]
doc["ensemble"]["realizations"] = 40
doc["sweep"]["loads.0.intensity"] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
study = vines_stoch.parse_scenario(tomlkit.dumps(doc), "ground_motion (shortened)", SCENARIOS)

# %%
# Run, then fit the curve of the ``drift`` limit against the swept intensity.
with tempfile.TemporaryDirectory() as out:
    vines_stoch.run(study, out, workers=1)
    stripes = fragility(out, "drift", "loads.0.intensity", samples=200, seed=0, plot=False)
fit = stripes.iloc[0]
print(f"median {fit['median']:.3f} [{fit['median_lo']:.3f}, {fit['median_hi']:.3f}], "
      f"beta {fit['beta']:.3f} [{fit['beta_lo']:.3f}, {fit['beta_hi']:.3f}]")

# %%
# The stripes with their intervals and the fitted curve.
fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
errors = [stripes["fraction"] - stripes["fraction_lo"], stripes["fraction_hi"] - stripes["fraction"]]
ax.errorbar(stripes["im"], stripes["fraction"], yerr=errors, fmt="o", capsize=3,
            label="exceeded fraction (95 % Wilson interval)")
im = np.linspace(0.05, 0.7, 200)
ax.plot(im, norm.cdf(np.log(im / fit["median"]) / fit["beta"]), label="lognormal fit")
ax.set_xlabel("white-noise intensity sigma of the ground motion")
ax.set_ylabel("P(drift > 0.15)")
ax.set_ylim(-0.02, 1.02)
ax.legend(loc="lower right")
plt.show()
