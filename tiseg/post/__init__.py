"""After a run: analysis of saved fields (fronts, fingers, deposits, spectra), rendering of
frames and movies, and the verification problems scored against exact solutions."""
