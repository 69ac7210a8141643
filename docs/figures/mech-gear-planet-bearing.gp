# The planet bearing's load in examples/gears/planetary.yaml, with the meshes through the pitch
# point (as shipped) and as torques between spins (contact: spin). The data files hold time, the
# tangential and the radial load on planet1's bearing in the carrier's frame (the bearing's force
# J.F turned by carrier.R^T), one line per row of results.csv:
#   gnuplot -e "pitch='pitch.dat'; spin='spin.dat'" docs/figures/mech-gear-planet-bearing.gp
set terminal svg size 760,360 font "sans,11" background "white"
set output "docs/figures/mech-gear-planet-bearing.svg"
set xlabel "t [s]"
set ylabel "planet1 bearing load [N]"
set key right center
set grid
set yrange [-20:380]
plot pitch using 1:2 with lines lw 2 title "tangential, contact: pitch", \
     spin using 1:2 with lines lw 2 dt 2 title "tangential, contact: spin", \
     pitch using 1:3 with lines lw 1 title "radial (m w_c^2 r), both", \
     333.333 with lines lc rgb "gray" dt 3 title "90 N m / (3 x 0.09 m)"
