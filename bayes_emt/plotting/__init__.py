"""All of bayes_emt's matplotlib code (never imported by the package ``__init__``).

Functions take results and an optional ``ax``, reject unknown keywords, return the figure, and
never call ``plt.show()``.
"""
