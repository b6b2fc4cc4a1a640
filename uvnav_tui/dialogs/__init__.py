"""The console's dialogs (Setup, Obs, Kalman and Demo menus), one module per dialog."""
