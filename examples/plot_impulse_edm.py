"""
EDM of the parallel NES against the impulse strength
=====================================================

``scenarios/parallel_nes_impulse.toml`` (seed 000, Wei et al.: a cubic NES and a vibro-impact NES
in parallel on a linear primary) swept over the impulse strength ``X``, with a shorter window and
fewer sweep points than the shipped file. The energy dissipation measure (EDM: the share of the
input energy the absorbers take out) is high over a band of impulses: below it the cubic NES is
not activated, above it the vibro-impact NES saturates.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import tomlkit

import vines_stoch

# The shipped scenarios: run from the repository or from examples/ (as the gallery does).
SCENARIOS = next(p / "scenarios" for p in (Path.cwd(), Path.cwd().parent) if (p / "scenarios").is_dir())
text = (SCENARIOS / "parallel_nes_impulse.toml").read_text()

# %%
# Shorten the shipped scenario: 100 s instead of 300 s, 9 impulses instead of 15.
doc = tomlkit.parse(text)
doc["simulation"]["duration"] = 100.0
doc["sweep"]["loads.0.velocity"] = {"logspace": [0.01, 10.0, 9]}
study = vines_stoch.parse_scenario(tomlkit.dumps(doc), "parallel_nes_impulse (shortened)", SCENARIOS)

# %%
# Run it into a temporary folder and read the summary: one row per sweep point.
with tempfile.TemporaryDirectory() as out:
    realizations, summary = vines_stoch.run(study, out, workers=1)
columns = ["loads.0.velocity", "edm_mean", "impacts_mean", "energy_residual_mean"]
print(summary[columns].to_string(index=False))

# %%
# EDM and the impact count against the impulse strength.
fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
ax.semilogx(summary["loads.0.velocity"], summary["edm_mean"], "o-", label="EDM")
ax.set_xlabel("impulse strength X (initial velocity of the primary)")
ax.set_ylabel("EDM (share of the input energy)")
ax.set_ylim(0, 1.05)
right = ax.twinx()
right.semilogx(summary["loads.0.velocity"], summary["impacts_mean"], "s--", color="C1", label="impacts")
right.set_ylabel("impacts in the window")
fig.legend(loc="outside upper center", ncols=2)
plt.show()
