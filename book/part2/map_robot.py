# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A robot on a map: likelihood-field Monte Carlo localization
#
# This chapter is being written.
