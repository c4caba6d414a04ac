# Type stubs for the lagrange package (units SI; arrays float64 numpy).
