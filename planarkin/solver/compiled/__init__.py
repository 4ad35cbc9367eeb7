"""The compiled route of the grid pass and the studies' solves, on numba: which route a job
takes and what the compiled functions are given (kernel), the cache numba keeps them in
(jitcache), the small functions the kernels share (helpers; the kinds' equations are
planarkin.elements.pointline's) and the entry points (points, kernels, gen, gen_each).
Imported only when a job takes the route: a small run never imports numba."""
