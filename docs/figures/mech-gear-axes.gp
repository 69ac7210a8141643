# The gear types' axis conventions of docs/mechanisms.md ("Tooth forces"), drawn with gnuplot:
#   gnuplot docs/figures/mech-gear-axes.gp   (writes docs/figures/mech-gear-axes.svg)
# Each panel: gear a (its axis out of the page, or as marked), the pitch point P, the direction t
# where a's pitch point moves as a turns positively, s (the separating force on b) and the line
# of action n of the drive flank (20 deg pressure angle), and the axis b must have.
set terminal svg size 1000,300 font "sans,11" background "white"
set output "docs/figures/mech-gear-axes.svg"
set multiplot layout 1,4
unset key; unset tics; unset border
set size ratio -1
set style arrow 1 head filled size 0.06,20 lw 2 lc rgb "#1f77b4"
set style arrow 2 head filled size 0.06,20 lw 2 lc rgb "#d62728"
set style arrow 3 head filled size 0.06,20 lw 2 lc rgb "#2ca02c"
set object 1 circle at 0,0 size 0.5 fc rgb "black" fs empty
set object 2 circle at 1.5,0 size 1.0 fc rgb "black" fs empty
set arrow 1 from 0.5,0 to 0.5,0.6 as 1
set arrow 2 from 0.5,0 to 1.0,0 as 2
set arrow 3 from 0.5,0 to 0.5+0.6*sin(20*pi/180),0.6*cos(20*pi/180) as 3
set label 1 "a: z" at -0.25,0; set label 2 "b: z" at 1.35,0
set label 3 "t" at 0.55,0.7; set label 4 "s" at 1.05,0.1; set label 5 "n" at 0.8,0.6; set label 6 "P" at 0.35,-0.12
set title "external spur: axes alike"
plot [-0.7:2.7][-1.2:1.2] NaN
unset object; unset arrow; unset label
set object 1 circle at 0,0 size 1.4 fc rgb "black" fs empty
set object 2 circle at 0.9,0 size 0.5 fc rgb "black" fs empty
set arrow 1 from 1.4,0 to 1.4,0.6 as 1
set arrow 2 from 1.4,0 to 0.9,0 as 2
set arrow 3 from 1.4,0 to 1.4-0.6*sin(20*pi/180),0.6*cos(20*pi/180) as 3
set label 1 "a (ring): z" at -0.6,0.3; set label 2 "b: -z" at 0.75,0
set label 3 "t" at 1.45,0.7; set label 4 "s" at 0.95,0.1; set label 5 "n" at 1.05,0.65; set label 6 "P" at 1.45,-0.12
set title "internal: axes opposite"
plot [-1.6:1.6][-1.6:1.6] NaN
unset object; unset arrow; unset label
set object 1 circle at 0,0.5 size 0.5 fc rgb "black" fs empty
set object 2 rect from -1.2,-0.3 to 1.2,0 fc rgb "black" fs empty
set arrow 1 from 0,0 to 0.6,0 as 1
set arrow 2 from 0,0 to 0,-0.5 as 2
set arrow 3 from 0,0 to 0.6*cos(20*pi/180),-0.6*sin(20*pi/180) as 3
set label 1 "a: z" at -0.2,0.5; set label 2 "b: rack" at -1.1,-0.45
set label 3 "t" at 0.62,0.08; set label 4 "s" at 0.05,-0.55; set label 5 "n" at 0.62,-0.3; set label 6 "P" at -0.15,0.1
set title "rack: moves along t"
plot [-1.3:1.3][-0.9:1.1] NaN
unset object; unset arrow; unset label
set arrow 4 from 0,0.3 to 0,-1.2 nohead lw 1 dt 2
set arrow 5 from 0,0 to -2.2,0 nohead lw 1 dt 2
set arrow 6 from -2,-0.5 to -2,0.5 nohead lw 3
set arrow 7 from -2,-0.5 to 2,-0.5 nohead lw 3
set arrow 8 from 0,0 to -2,-0.5 nohead lw 1 dt 3
set arrow 2 from -2,-0.5 to -2-0.6*0.2425,-0.5+0.6*0.97 as 2
set label 1 "a: z (crown)" at 0.1,-1.0; set label 2 "b: x (pinion)" at -2.3,0.75
set label 4 "s" at -2.35,0.0; set label 6 "P" at -2.0,-0.75; set label 7 "apex" at 0.1,0.15
set label 3 "t: into the page" at -1.6,-1.5
set title "bevel: b's axis = t x radial_b"
plot [-2.6:1.2][-2.4:1.0] NaN
unset multiplot
