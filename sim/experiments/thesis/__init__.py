"""The thesis's chapter 4 reproduced: `sortsim reproduce`'s pieces, their tables, figures and
blocks."""
