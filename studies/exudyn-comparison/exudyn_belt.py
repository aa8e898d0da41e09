"""The default beltwin drive geometry in Exudyn (ANCF Cable2D belt, ContactFrictionCircleCable2D),
for a side-by-side wall-time comparison with `rom simulate` on this machine.

Usage: python3 studies/exudyn-comparison/exudyn_belt.py N_ELEMENTS END_TIME_S
Drive: pulleys r 0.05 / 0.1 m at d = 0.42 m, belt EA 20 kN, EI 0.02 N m^2, 0.105 kg/m, static
tension 250 N (reference strain), friction 0.7; driver speed ramped to 1750 rpm in 0.2 s, a
light driven pulley (0.02 kg m^2) braked by 14.2 N m ramped in over 0.2 s. Exudyn's own belt
example settings: generalized-alpha, step 2.5e-4 s, 2 contact segments per element.
Prints wall time and the mean slip over the last 40 % of the run.
"""
import sys
import time
from math import pi

import exudyn as exu
import numpy as np
from exudyn.beams import CreateReevingCurve, PointsAndSlopes2ANCFCable2D
from exudyn.utilities import *  # noqa: F401,F403 (item interface)

n_el = int(sys.argv[1])
t_end = float(sys.argv[2])
r1, r2, d = 0.05, 0.1, 0.42
EA, EI, rhoA = 20000.0, 0.02, 0.105
T0 = 250.0
mu = 0.7
h = 0.008
omega_end = 1750 * 2 * pi / 60
torque = 14.2
step = 2.5e-4

SC = exu.SystemContainer()
mbs = SC.AddSystem()
circles = [[[0, 0], r1, "L"], [[d, 0], r2, "L"], [[0, 0], r1, "L"], [[d, 0], r2, "L"]]
reeving = CreateReevingCurve(circles, removeLastLine=True, numberOfANCFnodes=n_el,
                             graphicsNodeSize=0.01)
del circles[-1]
del circles[-1]
ground = mbs.AddObject(ObjectGround())
cable = Cable2D(physicsMassPerLength=rhoA, physicsBendingStiffness=EI,
                physicsAxialStiffness=EA, physicsAxialDamping=0.02 * EA * 1e-3,
                physicsReferenceAxialStrain=-T0 / EA, useReducedOrderIntegration=2)
ancf = PointsAndSlopes2ANCFCable2D(mbs, reeving["ancfPointsSlopes"], reeving["elementLengths"],
                                   cable, massProportionalLoad=[0, -9.81, 0],
                                   firstNodeIsLastNode=True)
k_contact = 1e7   # N/m^2 per unit belt length (Exudyn Cable2D contact); penetration ~0.5 mm at 250 N on r = 0.05 m
n_ground = mbs.AddNode(NodePointGround())
m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))
sensors = []
for i, (c, r, _) in enumerate(circles):
    inertia = 5.5e-3 if i == 0 else 0.02
    node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[c[0], c[1], 0]))
    body = mbs.AddObject(ObjectRigidBody2D(physicsMass=1.0, physicsInertia=inertia, nodeNumber=node))
    m_node = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
    m_fix = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[c[0], c[1], 0]))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[m_fix, m_node]))
    m_rot = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=2))
    if i == 0:
        def drive(mbs, t, item, offset):
            return offset * omega_end * min(t / 0.2, 1.0)
        mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground, m_rot], velocityLevel=True,
                                           offset=1.0, offsetUserFunction_t=drive))
    else:
        def load(mbs, t, vec):
            f = min(t / 0.2, 1.0)
            return [0, 0, -torque * f]
        mbs.AddLoad(Torque(markerNumber=m_node, loadVector=[0, 0, -torque],
                           loadVectorUserFunction=load))
    sensors.append(mbs.AddSensor(SensorNode(nodeNumber=node, storeInternal=True,
                                            outputVariableType=exu.OutputVariableType.AngularVelocity)))
    for el in ancf[1]:
        nseg = 2
        m_cable = mbs.AddMarker(MarkerBodyCable2DShape(bodyNumber=el, numberOfSegments=nseg,
                                                       verticalOffset=-h / 2))
        data = mbs.AddNode(NodeGenericData(initialCoordinates=[0.1] * nseg + [-2] * nseg + [0] * nseg,
                                           numberOfDataCoordinates=3 * nseg))
        mbs.AddObject(ObjectContactFrictionCircleCable2D(
            markerNumbers=[m_node, m_cable], nodeNumber=data, numberOfContactSegments=nseg,
            contactStiffness=k_contact, contactDamping=1e-3 * k_contact,
            frictionStiffness=0.2 * k_contact, frictionVelocityPenalty=1e-4 * 0.2 * k_contact,
            frictionCoefficient=mu, circleRadius=r - h / 2))
mbs.Assemble()
s = exu.SimulationSettings()
s.linearSolverType = exu.LinearSolverType.EigenSparse
s.solutionSettings.writeSolutionToFile = False  # noqa
s.solutionSettings.sensorsWritePeriod = 1e-3
s.parallel.numberOfThreads = 1
s.timeIntegration.endTime = t_end
s.timeIntegration.numberOfSteps = int(t_end / step)
s.timeIntegration.verboseMode = 0
s.timeIntegration.newton.useModifiedNewton = True
s.timeIntegration.newton.numericalDifferentiation.minimumCoordinateSize = 1
s.timeIntegration.discontinuous.maxIterations = 7
s.timeIntegration.generalizedAlpha.spectralRadius = 0.5
t0 = time.perf_counter()
mbs.SolveDynamic(s)
wall = time.perf_counter() - t0
w1 = mbs.GetSensorStoredData(sensors[0])
w2 = mbs.GetSensorStoredData(sensors[1])
sel = w1[:, 0] > 0.6 * t_end
slip = 100 * (1 - r2 * w2[sel, 3] / (r1 * w1[sel, 3]))
print(f"exudyn ANCF {n_el} elements, {t_end} s: wall {wall:.2f} s, mean slip {np.mean(slip):.4f} %, "
      f"driver {np.mean(w1[sel, 3]) * 60 / (2 * pi):.1f} rpm")
