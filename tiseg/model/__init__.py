"""The model: material constants and closures (Table 1, sections 2-3), the physical laws as
components (friction 3.4/3.7, large-particle transport 2.17, viscosity 3.8), steady uniform flows
(section 4), linear stability (section 5, appendices A-B) and exact solutions. Pure physics: no
grids, no files."""
