"""The system FMU (`nnfmu system build`): an SSP system's FMUs packed into one FMI 2 co-simulation FMU whose master,
written in C, is the loop nnfmu's own master runs (`templates/c/inner_loop.c`), planned from the same wiring
(`plan.py`), configured by a generated header (`config.py`) and packed with the parts' files (`build.py`)."""
