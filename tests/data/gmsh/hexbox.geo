// Structured hexahedral box: transfinite volume, recombined into hexahedra.
// Cells per direction: nx, ny, nz (override with -setnumber).
DefineConstant[ nx = 5, ny = 8, nz = 4 ];
Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {1, 2, 0}; Point(4) = {0, 2, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 3} = nx + 1;
Transfinite Curve{2, 4} = ny + 1;
Transfinite Surface{1};
Recombine Surface{1};
Extrude {0, 0, 0.5} { Surface{1}; Layers{nz}; Recombine; }
