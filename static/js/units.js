// SI inside; degrees and millimetres only where people read them.

const RAD_TO_DEG = 180 / Math.PI;

/** Factor from a joint's SI unit (rad or m) to what the page shows (deg or mm). */
function displayScale( joint ) {

	return joint.unit === 'm' ? 1000 : RAD_TO_DEG;

}

function displayUnit( joint ) {

	return joint.unit === 'm' ? 'mm' : '°';

}

/** A joint value for people: degrees for rotary joints, millimetres for linear ones. */
function formatJoint( value, joint ) {

	if ( ! Number.isFinite( value ) ) return '—';
	return `${( value * displayScale( joint ) ).toFixed( 1 )}${joint.unit === 'm' ? ' mm' : '°'}`;

}

export { RAD_TO_DEG, displayScale, displayUnit, formatJoint };
