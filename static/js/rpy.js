// Roll, pitch and yaw as the KUKA LBR iiwa's Transformation service defines them (server/kinematics/rpy.py): rotations
// about the fixed X, Y and Z axes in that order, R = Rz(yaw) Ry(pitch) Rx(roll), radians.
// The /fk endpoint answers in the same convention; the page's TCP readout uses this.
// A plain ES module (no three.js), so node can check it against the server's formulas.

const GIMBAL_LOCK_COS = 1e-8; // as server/kinematics/rpy.py

/** [roll, pitch, yaw] (rad) of the unit quaternion (qx, qy, qz, qw). */
function rpyFromQuaternion( qx, qy, qz, qw ) {

	const m00 = 1 - 2 * ( qy * qy + qz * qz );
	const m01 = 2 * ( qx * qy - qw * qz );
	const m10 = 2 * ( qx * qy + qw * qz );
	const m11 = 1 - 2 * ( qx * qx + qz * qz );
	const m20 = 2 * ( qx * qz - qw * qy );
	const m21 = 2 * ( qy * qz + qw * qx );
	const m22 = 1 - 2 * ( qx * qx + qy * qy );
	const cosPitch = Math.hypot( m00, m10 );
	const locked = cosPitch < GIMBAL_LOCK_COS;
	const pitch = Math.atan2( - m20, locked ? 0 : cosPitch );
	// At pitch = +-90 deg only yaw -/+ roll is defined: roll is 0 and yaw takes the turn.
	const roll = locked ? 0 : Math.atan2( m21, m22 );
	const yaw = locked ? - Math.atan2( m01, m11 ) : Math.atan2( m10, m00 );
	return [ roll, pitch, yaw ];

}

/** The unit quaternion [qx, qy, qz, qw] of R = Rz(yaw) Ry(pitch) Rx(roll) (rad). */
function quaternionFromRpy( roll, pitch, yaw ) {

	const cr = Math.cos( roll / 2 ), sr = Math.sin( roll / 2 );
	const cp = Math.cos( pitch / 2 ), sp = Math.sin( pitch / 2 );
	const cy = Math.cos( yaw / 2 ), sy = Math.sin( yaw / 2 );
	return [
		sr * cp * cy - cr * sp * sy,
		cr * sp * cy + sr * cp * sy,
		cr * cp * sy - sr * sp * cy,
		cr * cp * cy + sr * sp * sy,
	];

}

export { quaternionFromRpy, rpyFromQuaternion };
