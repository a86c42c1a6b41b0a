#!/usr/bin/env bash
# Regenerates docs/plots/atmosphere_*.png from the model: builds nvs_report_atmosphere, writes
# its CSVs to a temporary folder and plots them with gnuplot (Debian package gnuplot-nox).
# Usage: docs/plots/atmosphere.sh [BUILD_DIR]   (default build/release)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build/release}
cmake --build "$build" --target nvs_report_atmosphere >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
NVS_CONFIG_DIR="$root/config" "$build/tests/sim/sky/nvs_report_atmosphere" "$tmp"
adb="$tmp/adb.csv"
# make_adb's night rows (thesis Table 8-2): hours after 20:00 EDT, direct + night sky.
awk -F, 'NR>1 && $5!="" && $5+0>0 && $4+0<-5 {split($2,a,"T"); split(a[2],b,":"); h=b[1]+0;
  if (h<12) h+=24; print (h-20)+b[2]/60 "," $8+$9}' \
  "$root/tests/data/thesis/table8-2_illuminance_timeline_make_adb.csv" > "$adb"
gnuplot <<GP
set datafile separator ","
set terminal pngcairo size 900,560 font ",11" noenhanced
set output "$root/docs/plots/atmosphere_sky_vs_rho.png"
set title "Moonlit sky luminance along the Moon's vertical (Moon at 40°, phase 10°)"
set xlabel "elevation along the vertical through the Moon [deg] (Moon at 40; 90 = zenith; 180 = opposite horizon)"
set ylabel "luminance [cd/m²]"
set logscale y
set key top right
set xrange [0:180]
set arrow from 40, graph 0 to 40, graph 1 nohead dt 3
set grid
plot "$tmp/sky_vs_rho.csv" using 1:2 with lines lw 2 title "nvstim, visibility 100 km", \
     "" using 1:3 with lines lw 2 title "nvstim, 23 km", \
     "" using 1:4 with lines lw 2 title "nvstim, 5 km", \
     "" using 1:5 with points pt 7 ps 0.6 title "Krisciunas and Schaefer 1991, 100 km extinction (10 deg or more from the Moon)"
set output "$root/docs/plots/atmosphere_night_timeline.png"
set title "Horizontal illuminance, RIT, night of 6-7 Sep 1998 (full Moon)"
set xlabel "hours after 20:00 EDT"
set ylabel "illuminance [lx]"
unset arrow
set xrange [0:11]
set logscale y
set yrange [0.0005:0.5]
set key bottom center
plot "$tmp/night_timeline.csv" using 1:6 with lines lw 3 title "nvstim total, 23 km", \
     "" using 1:3 with lines lw 2 dt 2 title "moon direct, 23 km", \
     "" using 1:4 with lines lw 2 dt 3 title "lunar sky, 23 km", \
     "" using 1:7 with lines lw 1 title "total, 100 km", \
     "" using 1:8 with lines lw 1 title "total, 5 km", \
     "" using 1:5 with lines lw 1 lc rgb "black" title "night sky (Appendix G)", \
     "$adb" using 1:2 with points pt 5 ps 1.2 title "make_adb (thesis Table 8-2)"
GP
echo "wrote docs/plots/atmosphere_sky_vs_rho.png and atmosphere_night_timeline.png"
