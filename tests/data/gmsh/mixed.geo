// Mixed cells: prisms (extruded triangles), hexahedra (extruded transfinite quads), and a
// tetrahedral volume on top of the hexahedra, whose quad floor Gmsh closes with pyramids.
DefineConstant[ lc = 0.25 ];  // override with -setnumber lc ...
Point(1) = {0, 0, 0, lc}; Point(2) = {1, 0, 0, lc}; Point(3) = {2, 0, 0, lc};
Point(4) = {2, 1, 0, lc}; Point(5) = {1, 1, 0, lc}; Point(6) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 5}; Line(3) = {5, 6}; Line(4) = {6, 1};
Line(5) = {2, 3}; Line(6) = {3, 4}; Line(7) = {4, 5};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
Curve Loop(2) = {5, 6, 7, -2}; Plane Surface(2) = {2};
Transfinite Curve{5, 6, 7, 2} = 5;
Transfinite Surface{2}; Recombine Surface{2};
out[] = Extrude {0, 0, 0.5} { Surface{1, 2}; Layers{3}; Recombine; };
// out[] lists the top surface and volume of surface 1, then those of surface 2 after its sides.
hexTop = out[6];
Extrude {0, 0, 0.5} { Surface{hexTop}; }
