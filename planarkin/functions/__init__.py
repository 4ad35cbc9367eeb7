"""Driver functions of time with exact derivatives of every order: expressions (expr), tabulated
inputs (inputtable), motion laws (laws), chained motion profiles (motion) and the piecewise
functions they are built on (piecewise)."""
