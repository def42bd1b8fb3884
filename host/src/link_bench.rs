//! `gridrt bench link` (issue 6): wire bytes, payload efficiency and compression of the UART
//! link per pixel encoding, and the modelled frame time with transmission overlapped with
//! ray work, on one or several boards.
