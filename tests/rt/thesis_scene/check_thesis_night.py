#!/usr/bin/python3
"""diagnose on the thesis's night time-lapses (Tables 8-2 and 8-3, made by
nvs_thesis_scene_datasets from make_adb's illuminance timeline) names no cause that
docs/validation.md calls wrong.

The frames carry make_adb's illuminance, the model renders nvstim's: the difference is in the
stimulus, frame by frame, not in the camera. docs/validation.md ("The thesis datasets with the
open-world diagnosis") calls bright-source protection the wrong cause on both. The check:
  - no finding of status `named` (docs/contracts.md) is `bright_source_protection`;
  - protection, where it is reported, is a `candidate` whose cause says why;
  - the residual is reported as `unexplained` structure, with a character.

Usage: check_thesis_night.py NVSTIM DATASETS_TOOL THESIS_DIR WORK_DIR
"""
import json
import os
import shutil
import subprocess
import sys


def main():
    nvstim, tool, thesis, work = sys.argv[1:5]
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    subprocess.run([tool, thesis, work], check=True, stdout=subprocess.DEVNULL)
    failures = []
    for name in ("t8-2_night_illuminance", "t8-3_lunar_scattering"):
        out = os.path.join(work, name + ".json")
        subprocess.run([nvstim, "diagnose", os.path.join(work, name), "--json", out],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(out) as f:
            findings = json.load(f)["findings"]
        print(name + ":")
        for f in findings:
            label = f["effect"] + (" " + f["structure"] if "structure" in f else "")
            print("  %-40s %-12s z %6.1f" % (label, f["status"], f["z"]))
        for f in findings:
            if f["effect"] == "bright_source_protection":
                if f["status"] == "named":
                    failures.append(name + ": bright_source_protection is named")
                elif "candidate:" not in f["cause"]:
                    failures.append(name + ": protection is a candidate without a reason")
        if not any(f["status"] == "unexplained" and f.get("character") for f in findings):
            failures.append(name + ": no unexplained structure reported")
    for m in failures:
        print("FAIL " + m)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
